/*
 * A host's command text (the syntax of tools/tof_telemetry.py --send,
 * docs/reference/telemetry-protocol.md "Commands from a host") into a struct tlm_command, for
 * tlm_encode_command(): the one parser host_sim replay and tof_twin use for --command ROW:TEXT
 * (docs/reference/tools.md), so both send the same bytes. Host side; no heap, no floating point.
 *
 *     set-window N [tumbling|sliding]          N in TLM_WINDOW_MIN..TLM_WINDOW_MAX
 *     estimator|select-estimator consensus|consensus-paper|kalman|mean
 *     start | stop | status | status-request | save
 *     raw|raw-stream on|off
 *     process-noise|set-process-noise QD,QT|auto   mm²/s, up to 6 decimals, <= 4294.967295
 *     set-arm MM                               the arm a in mm, up to 3 decimals, 1..1000
 *     set-period MS                            the sample period in whole ms, 1..10000
 *     write-calibration HEX                    record section 2, 118 bytes as 236 hex digits
 *     read-calibration | re-zero N             N samples, 10..5000
 *
 * Words are separated by spaces; verbs and names in any case (write-calibration: lower case).
 */
#ifndef TELEMETRY_TLM_COMMAND_TEXT_H
#define TELEMETRY_TLM_COMMAND_TEXT_H

#include <stddef.h>
#include <stdint.h>

#include "telemetry/tlm_messages.h"

/*
 * Parse `text` into `out`. NULL on success; else a static message naming what is wrong
 * (an unknown verb, a missing or extra word, a value out of range), `out` then unspecified.
 */
const char *tlm_command_from_text(const char *text, struct tlm_command *out);

/*
 * A --command argument "ROW:TEXT": the trace row (decimal, up to 4294967295) in *row, the
 * command in `out`. NULL on success, else a static message (the ROW or the TEXT's).
 */
const char *tlm_command_from_arg(const char *arg, uint32_t *row, struct tlm_command *out);

#endif /* TELEMETRY_TLM_COMMAND_TEXT_H */
