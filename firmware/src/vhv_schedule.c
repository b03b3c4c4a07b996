/* When to rerun ST's temperature update on which part (firmware/vhv_schedule.h). */
#include "firmware/vhv_schedule.h"

void tof_vhv_schedule_init(struct tof_vhv_schedule *v) {
    for (unsigned i = 0; i < TOF_VHV_SENSORS; ++i) {
        v->ref_known[i] = false;
        v->ref_cdeg[i] = 0;
    }
    v->active = TOF_VHV_NONE;
}

void tof_vhv_calibrated(struct tof_vhv_schedule *v, unsigned sensor, bool known, int16_t cdeg) {
    if (sensor >= TOF_VHV_SENSORS) {
        return;
    }
    v->ref_known[sensor] = known;
    v->ref_cdeg[sensor] = (int16_t)(known ? cdeg : 0);
    if (v->active == sensor) {
        v->active = TOF_VHV_NONE;
    }
}

unsigned tof_vhv_due(struct tof_vhv_schedule *v, uint8_t ranging_mask, bool known, int16_t cdeg) {
    if (!known) {
        return TOF_VHV_NONE;
    }
    unsigned due = TOF_VHV_NONE;
    for (unsigned i = 0; i < TOF_VHV_SENSORS; ++i) {
        if (!v->ref_known[i]) {
            v->ref_known[i] = true;
            v->ref_cdeg[i] = cdeg;
            continue;
        }
        const int32_t moved = (int32_t)cdeg - v->ref_cdeg[i];
        const bool far = moved >= TOF_VHV_RERUN_CDEG || moved <= -TOF_VHV_RERUN_CDEG;
        if (far && (ranging_mask & (1u << i)) != 0u && due == TOF_VHV_NONE) {
            due = i;
        }
    }
    if (v->active != TOF_VHV_NONE) {
        return TOF_VHV_NONE;
    }
    v->active = (uint8_t)due;
    return due;
}
