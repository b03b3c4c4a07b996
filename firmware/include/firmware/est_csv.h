/*
 * The estimate CSV of docs/reference/tools.md, written by integer code only so host_sim
 * and the QEMU image produce byte-identical files:
 *
 *   t_ms,alpha_deg,beta_deg,distance_mm,status,alpha_sd_deg,beta_sd_deg,distance_sd_mm,why,temp_c
 *   1980,1.000123,-0.250000,100.012,ok,0.310000,0.305000,0.150,,21.37
 *   3980,,,,invalid,,,,no-target:A+no-target:C+unobservable,
 *
 * Angles and their sd have six decimals (micro-degrees, exact), the distance and its
 * sd three (micrometres, exact). An axis that is not estimated is left empty, its sd
 * too; `why` is attitude_why_format()'s text, empty when ok; `temp_c` the temperature of
 * the window's last row, two decimals (0.01 °C, exact), empty when the unit had none.
 */
#ifndef FIRMWARE_EST_CSV_H
#define FIRMWARE_EST_CSV_H

#include <stdbool.h>
#include <stdint.h>

#include "estimator/attitude.h"
#include "firmware/text.h"

#define TOF_EST_CSV_HEADER                                                                         \
    "t_ms,alpha_deg,beta_deg,distance_mm,status,alpha_sd_deg,beta_sd_deg,distance_sd_mm,why,"      \
    "temp_c\n"
/* longest row including '\n' and the terminator: 7 numbers of at most 12 characters, the
 * status, the why text and the temperature (",-327.68") */
#define TOF_EST_CSV_ROW_MAX (7u * 13u + 10u + ATTITUDE_WHY_TEXT_MAX + 8u + 2u)

/* Append one row (with '\n') for estimate `e` at trace time `t_ms`, with the temperature
 * `temp_cdeg` (0.01 °C) when `temp_known`, else an empty temp_c. */
void tof_est_csv_row(struct tof_text *t, uint32_t t_ms, const struct attitude_estimate *e,
                     bool temp_known, int16_t temp_cdeg);

#endif /* FIRMWARE_EST_CSV_H */
