/*
 * When to rerun ST's temperature update (the VL53L1X's VHV calibration) on which part. ST:
 * "call this function any time the temperature might have changed by more than 8 deg C"
 * ([ULD] VL53L1X_StartTemperatureUpdate; /work/shared/calibration-notes.md "Temperature").
 * Each part remembers the temperature of its last VHV calibration (its bring-up, a
 * re-initialisation, an update); a part whose reference is 8 °C or more away is due. One part
 * at a time, so the other three keep ranging. Pure logic, no I/O: the application carries
 * the updates out (firmware/src/app.c).
 */
#ifndef FIRMWARE_VHV_SCHEDULE_H
#define FIRMWARE_VHV_SCHEDULE_H

#include <stdbool.h>
#include <stdint.h>

#define TOF_VHV_SENSORS    4u
#define TOF_VHV_NONE       0xFFu
#define TOF_VHV_RERUN_CDEG 800 /* 8 °C */

struct tof_vhv_schedule {
    bool ref_known[TOF_VHV_SENSORS]; /* the temperature of the last calibration is known */
    int16_t ref_cdeg[TOF_VHV_SENSORS];
    uint8_t active; /* the part whose update runs, TOF_VHV_NONE: none */
};

/* No reference yet for any part, no update running. */
void tof_vhv_schedule_init(struct tof_vhv_schedule *v);

/* Part `sensor`'s VHV calibration has just run at this temperature (known false: unknown;
 * the next known temperature becomes its reference). Ends the update of that part. */
void tof_vhv_calibrated(struct tof_vhv_schedule *v, unsigned sensor, bool known, int16_t cdeg);

/*
 * With the temperature now (known false: none, nothing is due): a part without a reference
 * takes this one; the lowest-numbered part in `ranging_mask` (bit i: part i ranges and may
 * stop) whose reference is TOF_VHV_RERUN_CDEG or more away is due and becomes `active`.
 * Returns it, or TOF_VHV_NONE (none due, or an update already runs).
 */
unsigned tof_vhv_due(struct tof_vhv_schedule *v, uint8_t ranging_mask, bool known, int16_t cdeg);

#endif /* FIRMWARE_VHV_SCHEDULE_H */
