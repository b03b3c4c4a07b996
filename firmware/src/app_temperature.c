/* The head's temperature in the application: the read with each sample, ST's temperature
 * update's steps (firmware/app.h, "the head's temperature"). */
#include "firmware/app.h"

#include "hal/hal_err.h"

void tof_app_read_temperature(struct tof_app *app, struct tof_sample *sample) {
    sample->temp_known = false;
    sample->temp_cdeg = 0;
    const struct hal_temp *temp = &app->platform->temp;
    if (temp->ops == NULL || temp->ops->read_cdeg == NULL) {
        return; /* no sensor on this board */
    }
    int16_t cdeg = 0;
    const int err = temp->ops->read_cdeg(temp->ctx, &cdeg);
    app->temp_known = err == HAL_OK;
    app->temp_cdeg = cdeg;
    if (err != HAL_OK) {
        ++app->counters.temp_errors;
        app->counters.temp_last_error = err;
        return;
    }
    sample->temp_known = true;
    sample->temp_cdeg = cdeg;
}

/* The running update's end: counted, and the part's reference moved on success; on a failure
 * the reference stays, so it is tried again once the part is healthy (unless its
 * re-initialisation, which runs the VHV step, comes first). */
static void ended(struct tof_app *app, unsigned sensor, int err) {
    if (err == HAL_OK) {
        ++app->counters.temp_updates;
        tof_vhv_calibrated(&app->vhv, sensor, app->temp_known, app->temp_cdeg);
    } else {
        ++app->counters.temp_updates_failed;
        app->vhv.active = TOF_VHV_NONE;
    }
}

struct tof_temp_step_result tof_app_temperature_step(struct tof_app *app) {
    struct tof_temp_step_result r = {TOF_TEMP_STEP_IDLE, app->vhv.active, HAL_OK};
    if (r.sensor != TOF_VHV_NONE) {
        struct vl53_dev *dev = vl53_array_sensor(&app->array, r.sensor);
        r.err = vl53_temperature_update_pending(dev);
        if (r.err == HAL_ERR_NOT_READY) {
            r.err = HAL_OK;
            return r;
        }
        if (r.err == HAL_OK) {
            r.err = vl53_temperature_update_finish(dev);
        }
        ended(app, r.sensor, r.err);
        r.step = TOF_TEMP_STEP_ENDED;
        return r;
    }
    uint8_t ranging = 0u;
    for (unsigned i = 0; i < TOF_SENSORS; ++i) {
        const bool can_stop = app->health[i].state == TOF_HEALTH_HEALTHY &&
                              !app->start_pending[i] &&
                              vl53_is_ranging(vl53_array_sensor(&app->array, i));
        ranging = (uint8_t)(ranging | (can_stop ? 1u << i : 0u));
    }
    const unsigned due = tof_vhv_due(&app->vhv, ranging, app->temp_known, app->temp_cdeg);
    if (due == TOF_VHV_NONE) {
        return r;
    }
    struct vl53_dev *dev = vl53_array_sensor(&app->array, due);
    r.sensor = (uint8_t)due;
    r.step = TOF_TEMP_STEP_BEGUN;
    r.err = vl53_stop_ranging(dev);
    if (r.err == HAL_OK) {
        r.err = vl53_temperature_update_begin(dev);
    }
    if (r.err != HAL_OK) {
        ended(app, due, r.err); /* not run */
    }
    return r;
}

void tof_app_temperature_abandon(struct tof_app *app) {
    const unsigned s = app->vhv.active;
    if (s != TOF_VHV_NONE) {
        ended(app, s, vl53_temperature_update_finish(vl53_array_sensor(&app->array, s)));
    }
}
