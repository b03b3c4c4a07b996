/*
 * The estimate CSV of DESIGN.md §6, written by integer code only so host_sim
 * and the QEMU image produce byte-identical files:
 *
 *   t_ms,alpha_deg,beta_deg,distance_mm,status
 *   1980,1.000123,-0.250000,100.012,ok
 *   3980,,,,invalid
 *
 * Angles have six decimals (micro-degrees, exact), the distance three
 * (micrometres, exact). An axis that is not estimated is left empty.
 */
#ifndef FIRMWARE_EST_CSV_H
#define FIRMWARE_EST_CSV_H

#include <stdint.h>

#include "estimator/attitude.h"
#include "firmware/text.h"

#define TOF_EST_CSV_HEADER  "t_ms,alpha_deg,beta_deg,distance_mm,status\n"
#define TOF_EST_CSV_ROW_MAX 80u /* longest row including '\n' and the terminator */

/* Append one row (with '\n') for estimate `e` at trace time `t_ms`. */
void tof_est_csv_row(struct tof_text *t, uint32_t t_ms, const struct attitude_estimate *e);

#endif /* FIRMWARE_EST_CSV_H */
