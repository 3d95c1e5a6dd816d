/* hrrtc C client API: libhrrtc_c (crate ipc-types/c, `cargo build --release -p hrrtc-c`,
 * then link with -lhrrtc_c). The wire types are in hrrtc.h.
 *
 * Handles are not thread-safe: use each from the thread that opened it. On failure a
 * function returns NULL or -1 and hrrtc_last_error() says why. */
#ifndef HRRTC_CLIENT_H
#define HRRTC_CLIENT_H

#include "hrrtc.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct StateReaderHandle hrrtc_state_reader;
typedef struct GuidancePublisherHandle hrrtc_guidance_publisher;

/* Message of the last failure on this thread ("" if none); valid until the next call. */
const char *hrrtc_last_error(void);

/* CLOCK_MONOTONIC now, ns: the clock of every timestamp on the wire. */
uint64_t hrrtc_monotonic_ns(void);

/* Opens the newest generation of hrrtc/<ns>/haptic_state/<n>. NULL on failure. */
hrrtc_state_reader *hrrtc_state_reader_open(const char *ns);
/* Copies the newest state into *out: 1 = new since the last call, 0 = the same or none
 * yet (out->header.sequence == 0 then), -1 = bad arguments. Follows a restarted loop. */
int hrrtc_state_reader_read(hrrtc_state_reader *reader, hrrtc_HapticState *out);
/* The generation read. */
uint32_t hrrtc_state_reader_generation(const hrrtc_state_reader *reader);
void hrrtc_state_reader_close(hrrtc_state_reader *reader);

/* Opens a publisher of hrrtc/<ns>/guidance. NULL on failure. */
hrrtc_guidance_publisher *hrrtc_guidance_publisher_open(const char *ns);
/* Sends *g as it is (fill header.sequence from 1 and header.timestamp_ns from
 * hrrtc_monotonic_ns()) and wakes the loop's relay. 0, or -1 on failure. The loop renders
 * F_s = k * F_a, and rejects (and counts) samples it cannot trust. */
int hrrtc_guidance_publish(hrrtc_guidance_publisher *publisher, const hrrtc_Guidance *g);
void hrrtc_guidance_publisher_close(hrrtc_guidance_publisher *publisher);

#ifdef __cplusplus
}
#endif

#endif /* HRRTC_CLIENT_H */
