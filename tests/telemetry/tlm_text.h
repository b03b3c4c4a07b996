/*
 * Test helper: the canonical one-line text of every message, command,
 * rejection and counter set, as tools/tof_telemetry.py prints them. Two
 * independent implementations of one format let the tests prove that the C
 * encoder and the Python decoder agree on every field.
 */
#ifndef TLM_TEXT_H
#define TLM_TEXT_H

#include <stdint.h>
#include <stdio.h>

#include "telemetry/tlm_frame.h"
#include "telemetry/tlm_messages.h"

void tlm_text_telemetry(FILE *out, uint8_t seq, const struct tlm_telemetry *msg);
void tlm_text_command(FILE *out, uint8_t seq, const struct tlm_command *cmd);
void tlm_text_reject(FILE *out, uint8_t seq, uint8_t type, uint8_t length, enum tlm_result why);
void tlm_text_counters(FILE *out, const struct tlm_rx_counters *counters);

/*
 * Parse an accepted frame (command or telemetry) and print its line, or a
 * rejection line if a field is out of range (counted in `counters`).
 */
void tlm_text_frame(FILE *out, const struct tlm_frame *frame, struct tlm_rx_counters *counters);

#endif /* TLM_TEXT_H */
