/* Prints a running haptic loop's state ten times a second:
 *
 *   print_state NAMESPACE [COUNT [FORCE_N]]
 *
 * COUNT lines (default 20), then exit 0 (1 when no loop writes the namespace within 10 s). With FORCE_N it also publishes guidance whose
 * rendered force F_s is FORCE_N newtons along scene x (F_a = 1 cm, k = 100 * FORCE_N N/m),
 * as a planner would. Build (from the repository root):
 *
 *   cargo build --release -p hrrtc-c
 *   cc -std=c11 -Wall -Iipc-types/include ipc-types/c/examples/print_state.c \
 *      -Ltarget/release -lhrrtc_c -Wl,-rpath,target/release -o print_state
 */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "hrrtc_client.h"

static void sleep_ms(long ms) {
    struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
    nanosleep(&ts, NULL);
}

int main(int argc, char **argv) {
    if (argc < 2 || argc > 4) {
        fprintf(stderr, "usage: %s NAMESPACE [COUNT [FORCE_N]]\n", argv[0]);
        return 2;
    }
    long count = argc > 2 ? strtol(argv[2], NULL, 10) : 20;
    double force = argc > 3 ? strtod(argv[3], NULL) : NAN;
    if (count <= 0) {
        fprintf(stderr, "print_state: COUNT must be a positive integer, got %s\n", argv[2]);
        return 2;
    }
    hrrtc_state_reader *reader = hrrtc_state_reader_open(argv[1]);
    if (!reader) {
        fprintf(stderr, "print_state: %s\n", hrrtc_last_error());
        return 1;
    }
    hrrtc_guidance_publisher *publisher = NULL;
    if (!isnan(force)) {
        publisher = hrrtc_guidance_publisher_open(argv[1]);
        if (!publisher) {
            fprintf(stderr, "print_state: %s\n", hrrtc_last_error());
            hrrtc_state_reader_close(reader);
            return 1;
        }
    }
    hrrtc_HapticState s = {0};
    uint64_t sequence = 0;
    /* Every 10 ms: publish guidance (if asked); every 100 ms: print a line. */
    for (long step = 0, line = 0; line < count; step++) {
        if (publisher) {
            hrrtc_Guidance g = {0};
            g.header.sequence = ++sequence;
            g.header.timestamp_ns = hrrtc_monotonic_ns();
            g.attractive[0] = 0.01;         /* m, scene x */
            g.gain_n_per_m = 100.0 * force; /* N/m: F_s = 0.01 m * k = FORCE_N */
            g.time_to_live_ns = 200000000u; /* 0.2 s */
            g.mode = HRRTC_GUIDANCE_MODE_ROADMAP;
            if (hrrtc_guidance_publish(publisher, &g) != 0) {
                fprintf(stderr, "print_state: %s\n", hrrtc_last_error());
            }
        }
        sleep_ms(10);
        if (step % 10 != 9 || hrrtc_state_reader_read(reader, &s) < 0) {
            continue;
        }
        if (s.header.sequence == 0) {
            /* A reader may start before the loop; give up after 10 s. */
            if (step >= 1000) {
                fprintf(stderr, "print_state: no haptic loop writes namespace %s\n", argv[1]);
                break;
            }
            continue;
        }
        printf("seq %llu gen %u user_m %.4f %.4f %.4f commanded_n %.3f %.3f %.3f "
               "guidance_n %.3f %.3f %.3f freshness %u contact %u fault %u\n",
               (unsigned long long)s.header.sequence, hrrtc_state_reader_generation(reader),
               s.user_pose.position_m[0], s.user_pose.position_m[1], s.user_pose.position_m[2],
               s.commanded_wrench.force_n[0], s.commanded_wrench.force_n[1],
               s.commanded_wrench.force_n[2], s.guidance_wrench.force_n[0],
               s.guidance_wrench.force_n[1], s.guidance_wrench.force_n[2],
               s.guidance_freshness, s.contact, s.fault);
        fflush(stdout);
        line++;
    }
    int status = s.header.sequence == 0 ? 1 : 0;
    hrrtc_guidance_publisher_close(publisher);
    hrrtc_state_reader_close(reader);
    return status;
}
