"""Records the last seconds of a running haptic loop's forces and penetration and plots
them (or, without matplotlib, prints a summary per second).

    python ipc-types/python/examples/plot_force.py --namespace default --seconds 10 --png force.png

Start the loop first, e.g. `target/release/haptic-loop demo` or `haptic-loop run`.
"""

import argparse
import math
import sys
import time

import hrrtc


def norm(v):
    return math.sqrt(sum(x * x for x in v))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--namespace", default=hrrtc.DEFAULT_NAMESPACE)
    ap.add_argument("--seconds", type=float, default=10.0, help="how long to record, s")
    ap.add_argument("--png", help="write the plot here (needs matplotlib)")
    args = ap.parse_args()
    if not (args.seconds > 0 and math.isfinite(args.seconds)):
        ap.error(f"--seconds must be a finite number > 0, got {args.seconds}")

    node = hrrtc.create_node()
    try:
        reader = hrrtc.StateReader(node, args.namespace, timeout_s=10)
    except TimeoutError as e:
        sys.exit(f"plot_force: {e}")
    t, commanded, contact, guidance, penetration = [], [], [], [], []
    last = 0
    t0 = None
    end = time.monotonic() + args.seconds
    while time.monotonic() < end:
        s = reader.read()
        if s is None or s.header.sequence == last:
            time.sleep(0.0002)
            continue
        last = s.header.sequence
        t0 = t0 if t0 is not None else s.header.timestamp_ns
        t.append((s.header.timestamp_ns - t0) * 1e-9)
        commanded.append(norm(s.commanded_wrench.force_n))  # device frame, N
        contact.append(norm(s.contact_wrench.force_n))  # scene frame, N
        guidance.append(norm(s.guidance_wrench.force_n))  # scene frame, N
        penetration.append(s.penetration_m * 1e3)  # mm
    print(f"{len(t)} states in {args.seconds} s from namespace {args.namespace!r}")

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        plt = None
    if plt is None or not args.png:
        if args.png:
            print("matplotlib is not installed (pip install matplotlib): a summary instead")
        second = 0
        while second * 1.0 < (t[-1] if t else 0):
            idx = [i for i, x in enumerate(t) if second <= x < second + 1]
            if idx:
                print(
                    f"[{second:3d} s] commanded max {max(commanded[i] for i in idx):6.2f} N, "
                    f"contact max {max(contact[i] for i in idx):6.2f} N, "
                    f"F_s max {max(guidance[i] for i in idx):5.2f} N, "
                    f"penetration max {max(penetration[i] for i in idx):.3f} mm"
                )
            second += 1
        return
    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(9, 6))
    a.plot(t, commanded, label="commanded |F| (device frame)")
    a.plot(t, contact, label="contact |F| on the proxy")
    a.plot(t, guidance, label="guidance |F_s|")
    a.set_ylabel("N")
    a.legend()
    b.plot(t, penetration, color="tab:red")
    b.set_ylabel("penetration, mm")
    b.set_xlabel("s")
    fig.tight_layout()
    fig.savefig(args.png, dpi=110)
    print(f"wrote {args.png}")


if __name__ == "__main__":
    main()
