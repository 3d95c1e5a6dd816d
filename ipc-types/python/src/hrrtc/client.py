"""Readers and a guidance publisher for the haptic loop's and the planner's iceoryx2
services, on the official ``iceoryx2`` Python bindings.

Service names are ``hrrtc/<namespace>/<leaf>``:

- ``haptic_state/<generation>``: blackboard, key ``u64`` 0, value :class:`HapticState`,
  written by the haptic loop every tick. A loop restarted after a crash writes the next
  generation; the newest generation wins. :class:`StateReader` follows it.
- ``guidance``: publish-subscribe of :class:`Guidance` (planner -> loop), history 1.
- ``guidance_event``: event the planner notifies after each guidance sample (optional:
  the loop also polls).
- ``path``: publish-subscribe of :class:`Path`, history 1.
- ``roadmap``: publish-subscribe of :class:`Roadmap` increments, no history.

The quality-of-service values below are those the Rust side creates the services with
(``ipc_types::services``); opening with other values fails.
"""

import ctypes
import os
import time

import iceoryx2 as iox

from .wire import CONSTANTS, Guidance, GuidanceMode, HapticState, Header, Path, Roadmap

DEFAULT_NAMESPACE = "default"
MAX_READERS = 16
MAX_NODES = 32
LATEST_SUBSCRIBER_BUFFER = 2
MAX_PLANNER_PUBLISHERS = 4
ROADMAP_SUBSCRIBER_BUFFER = 10
ROADMAP_MAX_SUBSCRIBERS = 4
GENERATION_CHECK_S = 0.5
"""How long without a new state before a :class:`StateReader` looks for a newer
generation (a restarted loop), s."""

_KEY = ctypes.c_uint64(CONSTANTS["ENTRY_KEY"])


def service_name(namespace, leaf):
    """``hrrtc/<namespace>/<leaf>``."""
    return f"hrrtc/{namespace}/{leaf}"


def monotonic_ns():
    """CLOCK_MONOTONIC now, ns: the clock of every timestamp on the wire."""
    return time.clock_gettime_ns(time.CLOCK_MONOTONIC)


def create_node(name=None):
    """An iceoryx2 node for these services. iceoryx2's own console warnings (e.g. that no
    config file exists) are silenced unless ``IOX2_LOG_LEVEL`` is set."""
    iox.set_log_level_from_env_or(iox.LogLevel.Error)
    builder = iox.NodeBuilder.new()
    if name is not None:
        builder = builder.name(iox.NodeName.new(name))
    return builder.create(iox.ServiceType.Ipc)


def state_generations(namespace):
    """The generations of the state blackboard that exist on ``namespace``, ascending."""
    prefix = service_name(namespace, "haptic_state/")
    found = []
    for details in iox.Service.list(iox.config.global_config(), iox.ServiceType.Ipc):
        name = details.name().to_string()
        if name.startswith(prefix) and name[len(prefix):].isdigit():
            found.append(int(name[len(prefix):]))
    return sorted(found)


class StateReader:
    """Reads the newest :class:`HapticState` of a namespace and follows a restarted loop
    to its new generation (after :data:`GENERATION_CHECK_S` without a new state).

    ``read()`` returns the newest state (a copy) or ``None`` while no loop has written
    one. Polling it faster than the loop's rate sees every tick; ``header.sequence`` says
    how many were skipped.
    """

    def __init__(self, node, namespace=DEFAULT_NAMESPACE, timeout_s=10.0):
        self.node = node
        self.namespace = namespace
        deadline = time.monotonic() + timeout_s
        while True:
            generations = state_generations(namespace)
            if generations:
                break
            if time.monotonic() > deadline:
                raise TimeoutError(
                    f"no haptic loop state on namespace {namespace!r} "
                    f"({service_name(namespace, 'haptic_state/<n>')}) within {timeout_s} s"
                )
            time.sleep(0.05)
        self._open(generations[-1])

    def _open(self, generation):
        name = iox.ServiceName.new(service_name(self.namespace, f"haptic_state/{generation}"))
        factory = (
            self.node.service_builder(name)
            .blackboard_opener(ctypes.c_uint64)
            .max_readers(MAX_READERS)
            .open()
        )
        self._reader = factory.reader_builder().create()
        self._entry = self._reader.entry(_KEY, HapticState)
        self._factory = factory
        self.generation = generation
        self._last_sequence = 0
        self._last_new = time.monotonic()
        self._last_check = self._last_new

    def read(self):
        """The newest state, or ``None`` if the loop has not written one yet."""
        state = self._entry.get().decode_as(HapticState)
        now = time.monotonic()
        if state.header.sequence != self._last_sequence:
            self._last_sequence = state.header.sequence
            self._last_new = now
        elif now - self._last_new > GENERATION_CHECK_S and now - self._last_check > GENERATION_CHECK_S:
            self._last_check = now
            generations = state_generations(self.namespace)
            if generations and generations[-1] > self.generation:
                self._open(generations[-1])
                return self.read()
        return state if state.header.sequence != 0 else None


def _latest_value(node, namespace, leaf, payload):
    name = iox.ServiceName.new(service_name(namespace, leaf))
    return (
        node.service_builder(name)
        .publish_subscribe(payload)
        .history_size(1)
        .subscriber_max_buffer_size(LATEST_SUBSCRIBER_BUFFER)
        .enable_safe_overflow(True)
        .max_publishers(MAX_PLANNER_PUBLISHERS)
        .max_subscribers(MAX_READERS)
        .max_nodes(MAX_NODES)
        .open_or_create()
    )


def _roadmap(node, namespace):
    name = iox.ServiceName.new(service_name(namespace, "roadmap"))
    return (
        node.service_builder(name)
        .publish_subscribe(Roadmap)
        .history_size(0)
        .subscriber_max_buffer_size(ROADMAP_SUBSCRIBER_BUFFER)
        .enable_safe_overflow(True)
        .max_publishers(MAX_PLANNER_PUBLISHERS)
        .max_subscribers(ROADMAP_MAX_SUBSCRIBERS)
        .max_nodes(MAX_NODES)
        .open_or_create()
    )


class _Subscriber:
    def __init__(self, factory, payload):
        self._subscriber = factory.subscriber_builder().create()
        self._payload = payload

    def receive_all(self):
        """Every sample that arrived since the last call, oldest first (copies)."""
        out = []
        while True:
            sample = self._subscriber.receive()
            if sample is None:
                return out
            out.append(self._payload.from_buffer_copy(sample.payload().contents))
            sample.delete()

    def newest(self):
        """The newest sample that arrived since the last call, or ``None``."""
        samples = self.receive_all()
        return samples[-1] if samples else None


class GuidanceSubscriber(_Subscriber):
    """Subscriber of the planner's :class:`Guidance`."""

    def __init__(self, node, namespace=DEFAULT_NAMESPACE):
        super().__init__(_latest_value(node, namespace, "guidance", Guidance), Guidance)


class PathSubscriber(_Subscriber):
    """Subscriber of the planner's solution :class:`Path` (a late subscriber gets the
    newest one)."""

    def __init__(self, node, namespace=DEFAULT_NAMESPACE):
        super().__init__(_latest_value(node, namespace, "path", Path), Path)


class RoadmapSubscriber(_Subscriber):
    """Subscriber of the planner's :class:`Roadmap` increments (at most
    :data:`ROADMAP_MAX_SUBSCRIBERS` at once)."""

    def __init__(self, node, namespace=DEFAULT_NAMESPACE):
        super().__init__(_roadmap(node, namespace), Roadmap)


class GuidancePublisher:
    """Publishes :class:`Guidance` to the haptic loop, as a planner does: the loop renders
    F_s = k * F_a (force from ``attractive[0:3]`` m times ``gain_n_per_m``, torque from
    ``attractive[3:6]`` rad times ``gain_nm_per_rad``, scene frame), fades it out after
    ``time_to_live_ns`` and bounds it; samples it cannot trust (NaN, negative or absurd
    gains, unknown mode) are rejected and counted, never rendered."""

    def __init__(self, node, namespace=DEFAULT_NAMESPACE):
        factory = _latest_value(node, namespace, "guidance", Guidance)
        self._publisher = factory.publisher_builder().create()
        event = iox.ServiceName.new(service_name(namespace, "guidance_event"))
        self._notifier = (
            node.service_builder(event)
            .event()
            .max_notifiers(MAX_PLANNER_PUBLISHERS)
            .max_listeners(MAX_READERS)
            .max_nodes(MAX_NODES)
            .open_or_create()
            .notifier_builder()
            .create()
        )
        self.sequence = 0

    def publish(
        self,
        attractive,
        gain_n_per_m,
        gain_nm_per_rad=0.0,
        time_to_live_s=0.1,
        state_sequence=0,
        mode=GuidanceMode.ROADMAP,
    ):
        """Sends one sample stamped now: ``attractive`` is F_a, six numbers (m, then a
        rotation vector in rad, scene frame); the gains are N/m and N*m/rad. Returns the
        sample sent."""
        self.sequence += 1
        g = Guidance()
        g.header = Header(
            sequence=self.sequence,
            timestamp_ns=monotonic_ns(),
            writer_pid=os.getpid(),
            reserved=0,
        )
        for i, v in enumerate(attractive):
            g.attractive[i] = v
        g.gain_n_per_m = gain_n_per_m
        g.gain_nm_per_rad = gain_nm_per_rad
        g.time_to_live_ns = int(time_to_live_s * 1e9)
        g.state_sequence = state_sequence
        g.mode = mode
        self._publisher.send_copy(g)
        self._notifier.notify()
        return g
