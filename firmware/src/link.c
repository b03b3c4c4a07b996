/* The telemetry link: frames out, commands in, applied through app.h's interface. */
#include "firmware/link.h"

#include <string.h>

#include "firmware/calibration_record.h"
#include "hal/hal_err.h"
#include "telemetry/tlm_messages.h"

/* Firmware version as numbers for the status message (TOF_FW_VERSION "0.1.0"). */
#define FW_MAJOR 0u
#define FW_MINOR 1u
#define FW_PATCH 0u

static void send(struct tof_link *link, const uint8_t *frame, int len) {
    if (len <= 0 || link->serial.ops == NULL) {
        ++link->tx_dropped; /* an encoder refusal is a firmware defect: count it, never hide */
        return;
    }
    const size_t n = link->serial.ops->write(link->serial.ctx, frame, (size_t)len);
    if (n == (size_t)len) {
        ++link->tx_frames;
    } else {
        ++link->tx_dropped;
    }
    ++link->seq;
}

static void send_estimates(struct tof_link *link, const struct tof_estimate_record *record) {
    const struct attitude_output *out = &record->output;
    struct tof_app_status st;
    tof_app_get_status(link->app, &st);
    const uint16_t n = st.window;
    const bool sliding = st.sliding;
    for (unsigned e = 0; e < ATTITUDE_EST_COUNT; ++e) {
        const struct attitude_estimate *est = &out->est[e];
        if (est->reason == ATTITUDE_REASON_DISABLED) {
            continue;
        }
        uint8_t used = 0;
        for (unsigned k = 0; k < TOF_SENSORS; ++k) {
            used = (uint8_t)(used | (est->counts[k].used > 0u ? 1u << k : 0u));
        }
        /* Each value with its sd, or neither: what the estimator could not estimate has
         * no sd either (docs/reference/telemetry-protocol.md). */
        const bool a = est->alpha_valid, b = est->beta_valid, d = est->distance_valid;
        const struct tlm_estimate msg = {
            .t_ms = (uint32_t)(record->t_us / 1000u),
            .window_index = sliding ? out->last_row : out->last_row / n,
            .estimator = (uint8_t)e, /* enum attitude_estimator matches enum tlm_estimator */
            .status = (uint8_t)est->status,
            .sensors_used = est->status == ATTITUDE_OK ? TLM_SENSOR_MASK_ALL : used,
            .alpha_udeg = a ? est->alpha_udeg : TLM_NO_VALUE,
            .beta_udeg = b ? est->beta_udeg : TLM_NO_VALUE,
            .distance_um = d ? est->distance_um : TLM_NO_VALUE,
            .flatness_um = est->flatness_valid ? est->flatness_residual_um : TLM_NO_VALUE,
            .alpha_sd_udeg = a ? est->alpha_sd_udeg : TLM_NO_VALUE,
            .beta_sd_udeg = b ? est->beta_sd_udeg : TLM_NO_VALUE,
            .distance_sd_um = d ? est->distance_sd_um : TLM_NO_VALUE,
            .why = est->why, /* the estimator's bits, unchanged */
            .temp_known = record->temp_known,
            .temp_cdeg = (int16_t)(record->temp_known ? record->temp_cdeg : 0),
        };
        uint8_t frame[TLM_FRAME_MAX];
        send(link, frame, tlm_encode_estimate(link->seq, &msg, frame, sizeof frame));
    }
}

/* Not inlined: its message and frame stay off tof_link_poll()'s frame, under which the
 * decoder's callbacks run (tools/stack_check.py). */
static __attribute__((noinline)) void send_health(struct tof_link *link) {
    struct tof_app_health h;
    tof_app_get_health(link->app, &h);
    struct tlm_health msg;
    memset(&msg, 0, sizeof msg);
    msg.uptime_ms = (uint32_t)(h.uptime_us / 1000u);
    for (unsigned i = 0; i < TOF_SENSORS; ++i) {
        msg.sensor_state[i] = (uint8_t)h.state[i]; /* same order as tlm_sensor_health */
        msg.sensor[i].comm_errors = h.read_errors[i];
        msg.sensor[i].reinits = h.losses[i];
    }
    msg.bus.addr_nack = h.errors_by_code[-HAL_ERR_ADDR_NACK];
    msg.bus.data_nack = h.errors_by_code[-HAL_ERR_DATA_NACK];
    msg.bus.busy = h.errors_by_code[-HAL_ERR_BUS_BUSY];
    msg.bus.timeout = h.errors_by_code[-HAL_ERR_TIMEOUT];
    msg.bus.stuck = h.errors_by_code[-HAL_ERR_BUS_STUCK];
    /* The frame has no room for the rest (docs/reference/telemetry-protocol.md §5.3): every other
     * hal code, HAL_ERR_DEVICE among them, and any other module's code count as "other". */
    for (unsigned slot = 0; slot < TOF_ERROR_SLOTS; ++slot) {
        const bool own_field =
            slot == (unsigned)-HAL_ERR_ADDR_NACK || slot == (unsigned)-HAL_ERR_DATA_NACK ||
            slot == (unsigned)-HAL_ERR_BUS_BUSY || slot == (unsigned)-HAL_ERR_TIMEOUT ||
            slot == (unsigned)-HAL_ERR_BUS_STUCK;
        if (!own_field) {
            msg.bus.other += h.errors_by_code[slot];
        }
    }
    msg.bus.recoveries = h.bus_recoveries;
    msg.loop_overruns = h.overruns;
    msg.loop_max_us = h.max_iteration_us;
    msg.tx_dropped = link->tx_dropped;
    if (link->serial.ops->rx_lost != NULL) {
        msg.uart_overruns = link->serial.ops->rx_lost(link->serial.ctx);
    }
    msg.link = link->decoder.counters;
    uint8_t frame[TLM_FRAME_MAX];
    send(link, frame, tlm_encode_health(link->seq, &msg, frame, sizeof frame));
}

static void on_estimate(void *ctx, const struct tof_estimate_record *record) {
    struct tof_link *link = ctx;
    if (link->app == NULL) {
        return;
    }
    send_estimates(link, record);
    link->temp_known = record->temp_known; /* the unit's temperature, for the status frame */
    link->temp_cdeg = record->temp_cdeg;
    if (link->health_polls == 0u && (!link->health_sent || record->t_us >= link->health_due_us)) {
        link->health_polls = 2u; /* not postponed by later estimates (sliding mode) */
        link->health_sent = true;
        link->health_due_us = record->t_us + TOF_LINK_HEALTH_PERIOD_US;
    }
}

static void send_calibration(struct tof_link *link);

/* Around a calibration write (a re-zero's or one written): the estimator takes the new
 * calibration at age 0 in the write's own restart (attitude_init() runs once); once it is in
 * force its age restarts on storage, its first entry written by a poll once the record's own
 * save is done (one storage operation at a time); a refused one leaves the age as it was. */
static uint32_t age_hold(struct tof_link *link) {
    const uint32_t before = link->app->estimator.cfg.calibration_age_s;
    (void)tof_app_set_calibration_age(link->app, 0u, false);
    return before;
}

static void age_after_write(struct tof_link *link, enum tof_cal_state st, uint32_t before) {
    if (st != TOF_CAL_APPLIED) {
        (void)tof_app_set_calibration_age(link->app, before, false);
    } else if (link->cal_age != NULL) { /* set with the storage only */
        (void)link->storage->age_restart(link->cal_age, link->storage->cal_tag(link->records),
                                         tof_app_now_us(link->app));
    }
}

/* The calibration's age the estimator counts (tof_app_calibration_age_s()): the stored age at
 * boot plus its rows since, on every target alike. */
static uint32_t age_now_s(struct tof_link *link) {
    return tof_app_calibration_age_s(link->app);
}

/* The re-zero's last sample is in: the offsets refitted, saved and in force (or the reason
 * not: a thermal calibration without the samples' temperature is rejected, firmware/rezero.h),
 * the raw stream as the user had it, and a calibration message says how it went. */
static void finish_rezero(struct tof_link *link) {
    struct calibration_head now, next;
    tof_app_get_calibration(link->app, &now);
    int error = 0;
    enum tof_cal_state st = TOF_CAL_NO_STORAGE; /* a re-zero nothing could keep */
    bool fitted = false;
    if (link->storage != NULL) {
        st = TOF_CAL_REJECTED;
        fitted = link->storage->rezero_fit(&link->rezero, &now, &next);
    }
    if (fitted) {
        const uint32_t age_before = age_hold(link);
        st = link->storage->cal_write_head(link->records, link->app, &next, &error);
        age_after_write(link, st, age_before);
    }
    link->rezero.wanted = 0u;
    tof_app_set_raw_output(link->app, link->rezero_raw);
    const uint8_t kept = link->cal_state;
    link->cal_state = (uint8_t)st; /* this message says how the re-zero went */
    send_calibration(link);
    link->cal_state = st == TOF_CAL_APPLIED ? (uint8_t)st : kept;
}

static void on_sample(void *ctx, const struct tof_sample *sample) {
    struct tof_link *link = ctx;
    if (link->rezero.wanted != 0u) {
        if (tof_rezero_add(&link->rezero, sample)) {
            finish_rezero(link);
        }
        if (!link->rezero_raw) {
            return; /* raw on for the re-zero only: nothing sent */
        }
    }
    const struct tlm_raw_sample msg = {
        .t_ms = (uint32_t)(sample->t_us / 1000u),
        .range_mm = {sample->range_mm[0], sample->range_mm[1], sample->range_mm[2],
                     sample->range_mm[3]},
        .range_status = {sample->status[0], sample->status[1], sample->status[2],
                         sample->status[3]},
        .present_mask = sample->present_mask,
    };
    uint8_t frame[TLM_FRAME_MAX];
    send(link, frame, tlm_encode_raw_sample(link->seq, &msg, frame, sizeof frame));
}

const struct tof_output_ops tof_link_output_ops = {.estimate = on_estimate, .sample = on_sample};

void tof_link_send_status(struct tof_link *link) {
    struct tof_app_status st;
    tof_app_get_status(link->app, &st);
    const struct tlm_status msg = {
        .fw_major = FW_MAJOR,
        .fw_minor = FW_MINOR,
        .fw_patch = FW_PATCH,
        .uptime_ms = (uint32_t)(st.uptime_us / 1000u),
        .window_n = st.window,
        .mode = st.sliding ? TLM_WINDOW_SLIDING : TLM_WINDOW_TUMBLING,
        .estimator = (uint8_t)st.primary,
        .running = st.running,
        .raw_stream = st.raw_output,
        .period_ms = (uint16_t)(st.period_us / 1000u),
        .record = link->record_state,   /* enum tof_record_state == enum tlm_record_state */
        .calibration = link->cal_state, /* enum tof_cal_state == enum tlm_cal_state */
        .arm_um = (uint32_t)st.arm_um,  /* the estimator keeps it in 1..1000 mm */
        .cal_age_s = age_now_s(link),
        .cal_age = link->cal_age != NULL ? link->cal_age->state : (uint8_t)TOF_CAL_AGE_NONE,
        /* the last window's, while it runs: stopped, the unit reads none */
        .temp_known = st.running && link->temp_known,
        .temp_cdeg = (int16_t)(st.running && link->temp_known ? link->temp_cdeg : 0),
    };
    uint8_t frame[TLM_FRAME_MAX];
    send(link, frame, tlm_encode_status(link->seq, &msg, frame, sizeof frame));
}

/* An ack (result 0) or nack; `error` is the firmware's own code behind a refusal
 * (an attitude_error for the estimator's), 0 when there is none. */
static void answer(struct tof_link *link, uint8_t seq, uint8_t command, uint8_t result, int error) {
    const struct tlm_ack msg = {
        .echo_seq = seq, .command = command, .result = result, .error = (int8_t)error};
    uint8_t frame[TLM_FRAME_MAX];
    send(link, frame, tlm_encode_ack(link->seq, &msg, frame, sizeof frame));
}

/* The wire result of an estimator refusal: a value out of its range, or a state that
 * does not allow it. The code itself travels unchanged in the nack's `error`. */
static uint8_t estimator_result(int err) {
    if (err == ATTITUDE_ERR_NONE) {
        return TLM_RESULT_OK;
    }
    return err == ATTITUDE_ERR_WINDOW || err == ATTITUDE_ERR_MODE ||
                   err == ATTITUDE_ERR_KALMAN_PROCESS_NOISE || err == ATTITUDE_ERR_ARM
               ? TLM_RESULT_OUT_OF_RANGE
               : TLM_RESULT_STATE;
}

/* write-calibration (docs/reference/telemetry-protocol.md): saved and in force, or refused naming
 * the cause. Refused as busy while a re-zero runs (its result would overwrite this one) or a record
 * write is in progress (the record in use is about to change): never acknowledged and then
 * lost. */
static uint8_t write_calibration(struct tof_link *link, const uint8_t *section, int *error) {
    if (link->rezero.wanted != 0u || link->save_pending) {
        return TLM_RESULT_BUSY;
    }
    if (link->storage == NULL) {
        *error = HAL_ERR_STATE; /* nowhere to keep it: never in force for one boot only */
        return TLM_RESULT_STATE;
    }
    const uint32_t age_before = age_hold(link);
    const enum tof_cal_state st =
        link->storage->cal_write(link->records, link->app, section, error);
    age_after_write(link, st, age_before);
    switch (st) {
    case TOF_CAL_APPLIED:
        link->cal_state = (uint8_t)st; /* what the status frame says from now on */
        return TLM_RESULT_OK;
    case TOF_CAL_CORRUPT:
    case TOF_CAL_VERSION:
        return TLM_RESULT_OUT_OF_RANGE;
    case TOF_CAL_OTHER_HEAD:
        return TLM_RESULT_OTHER_HEAD;
    case TOF_CAL_OTHER_PARTS:
        return TLM_RESULT_OTHER_PARTS;
    case TOF_CAL_OTHER_MODE:
        return TLM_RESULT_OTHER_MODE;
    case TOF_CAL_OTHER_BUDGET:
        return TLM_RESULT_OTHER_BUDGET;
    case TOF_CAL_OTHER_ARM:
        return TLM_RESULT_OTHER_ARM;
    default:
        return TLM_RESULT_STATE; /* no storage, or the estimator refused it (*error says) */
    }
}

/* re-zero: refused without a calibration in force or while one runs; else samples are
 * collected (the raw stream on meanwhile) and finish_rezero() answers with a calibration
 * message once they are in. */
static uint8_t start_rezero(struct tof_link *link, uint16_t samples) {
    struct calibration_head now;
    tof_app_get_calibration(link->app, &now);
    if (link->rezero.wanted != 0u || link->save_pending) {
        return TLM_RESULT_BUSY; /* one re-zero at a time; not while the record is written */
    }
    if (!now.calibrated) {
        return TLM_RESULT_STATE;
    }
    if (!tof_rezero_start(&link->rezero, samples)) {
        return TLM_RESULT_OUT_OF_RANGE;
    }
    struct tof_app_status st;
    tof_app_get_status(link->app, &st);
    link->rezero_raw = st.raw_output;
    tof_app_set_raw_output(link->app, true);
    return TLM_RESULT_OK;
}

/* The calibration message: the state in force and the stored section. */
static void send_calibration(struct tof_link *link) {
    struct tlm_calibration msg = {.state = link->cal_state};
    if (link->storage != NULL) { /* else no section: all zero */
        link->storage->cal_read(link->records, msg.section);
    }
    uint8_t frame[TLM_FRAME_MAX];
    send(link, frame, tlm_encode_calibration(link->seq, &msg, frame, sizeof frame));
}

/* The stored calibration checked against the unit as it now runs (no storage: none). */
static uint8_t recheck(struct tof_link *link) {
    return link->storage != NULL ? (uint8_t)link->storage->cal_recheck(link->records, link->app)
                                 : link->cal_state;
}

/* set-arm and set-period (geometry and rate at run time). A new period changes the
 * timing budget, which the stored calibration is bound to: it is checked again, and the
 * status frame says whether it still holds. */
static uint8_t apply_geometry(struct tof_link *link, const struct tlm_command *cmd, int *error) {
    if (cmd->type == TLM_TYPE_SET_ARM) {
        *error = tof_app_set_arm(link->app, (int32_t)cmd->u.arm_um);
        if (*error == 0) {
            /* the stored calibration holds at its own arm only (other-arm elsewhere); the
             * status frame after the ack says which */
            link->cal_state = recheck(link);
        }
        return estimator_result(*error);
    }
    const uint16_t budget_ms = link->app->cfg.timing.budget_ms;
    *error = tof_app_set_period(link->app, cmd->u.period_ms);
    if (*error == HAL_ERR_INVALID) {
        return TLM_RESULT_OUT_OF_RANGE; /* no timing of the distance mode fits: a hal code */
    }
    if (*error == 0 && link->app->cfg.timing.budget_ms != budget_ms) {
        link->cal_state = recheck(link);
    }
    return estimator_result(*error);
}

/* Apply a validated command; returns the result code to answer with and sets *error to
 * the application's code behind a refusal (0 if none). */
static uint8_t apply(struct tof_link *link, const struct tlm_command *cmd, int *error) {
    struct tof_app *app = link->app;
    *error = 0;
    switch (cmd->type) {
    case TLM_TYPE_SET_WINDOW:
        *error = tof_app_set_window(app, cmd->u.set_window.window_n,
                                    cmd->u.set_window.mode == TLM_WINDOW_SLIDING);
        return estimator_result(*error);
    case TLM_TYPE_SELECT_ESTIMATOR:
        /* the parser checked the range: a refusal is an estimator that does not run */
        *error = tof_app_set_primary(app, (enum attitude_estimator)cmd->u.estimator);
        return estimator_result(*error);
    case TLM_TYPE_SET_PROCESS_NOISE:
        *error = tof_app_set_process_noise(
            app, cmd->u.process_noise.qd_um2_per_s, cmd->u.process_noise.qt_um2_per_s,
            (cmd->u.process_noise.flags & TLM_PROCESS_NOISE_AUTO) != 0u);
        if (*error == ATTITUDE_ERR_NONE) { /* kept for `save`: the app holds Q per row only */
            link->process_noise = (struct tof_settings){
                .process_noise_set = true,
                .process_noise_auto = (cmd->u.process_noise.flags & TLM_PROCESS_NOISE_AUTO) != 0u,
                .qd_um2_per_s = cmd->u.process_noise.qd_um2_per_s,
                .qt_um2_per_s = cmd->u.process_noise.qt_um2_per_s};
        }
        return estimator_result(*error);
    case TLM_TYPE_START:
        tof_app_set_running(app, true);
        return TLM_RESULT_OK;
    case TLM_TYPE_STOP:
        tof_app_set_running(app, false);
        return TLM_RESULT_OK;
    case TLM_TYPE_RAW_STREAM:
        tof_app_set_raw_output(app, cmd->u.raw_enable);
        return TLM_RESULT_OK;
    case TLM_TYPE_STATUS_REQUEST:
        return TLM_RESULT_OK; /* the status frame follows the ack */
    case TLM_TYPE_WRITE_CALIBRATION:
        return write_calibration(link, cmd->u.cal_section, error);
    case TLM_TYPE_READ_CALIBRATION:
        return TLM_RESULT_OK; /* the calibration message follows the ack */
    case TLM_TYPE_REZERO:
        return start_rezero(link, cmd->u.rezero_samples);
    case TLM_TYPE_SET_ARM:
    case TLM_TYPE_SET_PERIOD:
        return apply_geometry(link, cmd, error);
    case TLM_TYPE_SAVE: {
        /* Begun here, advanced by each poll (a page erase outlasts a loop iteration). */
        if (link->save_pending) {
            *error = HAL_ERR_STATE; /* the save before is still being written: answered then */
            return TLM_RESULT_STATE;
        }
        if (link->storage == NULL) {
            *error = HAL_ERR_STATE; /* no storage */
            return TLM_RESULT_STATE;
        }
        struct tof_settings now;
        tof_settings_capture(app, &link->process_noise, &now);
        *error = link->storage->settings_save_begin(link->records, &now); /* storage's own */
        /* Two steps now: the blank check, then the program when the page was blank (a
         * millisecond or two), so the answer goes out with this poll; when it was not, the
         * second step finds its erase running and the answer waits for it in save_poll(). */
        for (unsigned n = 0; n < 2u && *error == HAL_OK; ++n) {
            *error = link->storage->record_step(link->records);
            link->save_pending = *error == HAL_ERR_NOT_READY;
            *error = link->save_pending ? HAL_OK : *error;
        }
        return *error == HAL_OK || link->save_pending ? TLM_RESULT_OK : TLM_RESULT_STATE;
    }
    default:
        return TLM_RESULT_UNKNOWN_TYPE;
    }
}

/* The commands whose ack a status frame follows: a status request, and set-arm and
 * set-period, which can take the stored calibration out of force (or back into it). */
static bool status_follows(uint8_t type) {
    return type == TLM_TYPE_STATUS_REQUEST || type == TLM_TYPE_SET_ARM ||
           type == TLM_TYPE_SET_PERIOD;
}

/* A retry of the command answered last (the same bytes: sequence, type and payload)? Then
 * answer it as before without applying it again: its answer was lost, not the command. */
static bool answer_retry(struct tof_link *link, const struct tlm_frame *frame) {
    if (!link->last_valid || frame->seq != link->last_seq || frame->type != link->last_type ||
        frame->length != link->last_length ||
        memcmp(frame->payload, link->last_payload, frame->length) != 0) {
        return false;
    }
    ++link->commands_repeated;
    answer(link, frame->seq, frame->type, link->last_result, link->last_error);
    if (link->last_result == TLM_RESULT_OK && status_follows(frame->type)) {
        tof_link_send_status(link);
    }
    if (link->last_result == TLM_RESULT_OK && frame->type == TLM_TYPE_READ_CALIBRATION) {
        send_calibration(link);
    }
    return true;
}

static void on_frame(void *ctx, const struct tlm_frame *frame) {
    struct tof_link *link = ctx;
    if (answer_retry(link, frame)) {
        return;
    }
    struct tlm_command cmd;
    uint8_t result = (uint8_t)tlm_parse_command(frame, &cmd, &link->decoder.counters);
    int error = 0;
    if (result == TLM_RESULT_OK) {
        const bool saving = link->save_pending;
        result = apply(link, &cmd, &error);
        if (!saving && link->save_pending && frame->type == TLM_TYPE_SAVE) {
            link->save_seq = frame->seq; /* answered by save_poll() when the copy is in use */
            link->last_valid = false;
            return;
        }
        if (result == TLM_RESULT_OK) {
            ++link->commands_ok;
        } else {
            ++link->commands_refused;
        }
    }
    answer(link, frame->seq, frame->type, result, error);
    link->last_valid = frame->length <= TOF_LINK_COMMAND_MAX;
    link->last_seq = frame->seq;
    link->last_type = frame->type;
    link->last_length = frame->length <= TOF_LINK_COMMAND_MAX ? frame->length : 0u;
    memcpy(link->last_payload, frame->payload, link->last_length);
    link->last_result = result;
    link->last_error = (int8_t)error;
    if (result == TLM_RESULT_OK && status_follows(frame->type)) {
        tof_link_send_status(link);
    }
    if (result == TLM_RESULT_OK && frame->type == TLM_TYPE_READ_CALIBRATION) {
        send_calibration(link);
    }
}

static void on_reject(void *ctx, const struct tlm_reject *reject) {
    struct tof_link *link = ctx;
    answer(link, reject->seq, reject->type, (uint8_t)reject->reason, 0);
}

void tof_link_init(struct tof_link *link, struct hal_serial serial) {
    memset(link, 0, sizeof *link);
    link->serial = serial;
    link->record_state = TOF_RECORD_NO_STORAGE;
    link->cal_state = TOF_CAL_NO_STORAGE;
    tlm_decoder_init(&link->decoder, tlm_message_types(TLM_ACCEPT_COMMANDS));
}

void tof_link_set_records(struct tof_link *link, const struct tof_link_storage_ops *ops,
                          struct tof_record_store *store) {
    link->storage = ops;
    link->records = store;
}

void tof_link_set_cal_age(struct tof_link *link, struct tof_cal_age *age) {
    link->cal_age = age;
}

void tof_link_bind(struct tof_link *link, struct tof_app *app) {
    link->app = app;
}

/* The record save under way, one step a poll; a pending `save` answered when it ends. */
static __attribute__((noinline)) void save_poll(struct tof_link *link) {
    if (link->storage == NULL || !link->storage->record_busy(link->records)) {
        return;
    }
    const int rc = link->storage->record_step(link->records);
    if (!link->save_pending || rc == HAL_ERR_NOT_READY) {
        return; /* still writing, or the old page's erase after the answer */
    }
    link->save_pending = false;
    const uint8_t result = rc == HAL_OK ? TLM_RESULT_OK : TLM_RESULT_STATE;
    answer(link, link->save_seq, TLM_TYPE_SAVE, result, rc);
    if (result == TLM_RESULT_OK) {
        ++link->commands_ok;
    } else {
        ++link->commands_refused;
    }
}

void tof_link_poll(struct tof_link *link) {
    if (link->serial.ops == NULL || link->app == NULL) {
        return;
    }
    save_poll(link); /* not inlined for the same reason as send_health() */
    if (link->cal_age != NULL && link->cal_age->counting &&
        !link->storage->record_busy(link->records)) {
        /* never while the record's erase runs in the background: one storage, one operation */
        (void)link->storage->age_poll(link->cal_age, tof_app_now_us(link->app));
    }
    uint8_t buf[TOF_LINK_RX_PER_POLL];
    const struct tlm_frame_sink sink = {.on_frame = on_frame, .on_reject = on_reject, .ctx = link};
    for (unsigned chunk = 0; chunk < TOF_LINK_RX_CHUNKS; ++chunk) {
        const size_t n = link->serial.ops->read(link->serial.ctx, buf, sizeof buf);
        if (n == 0u) {
            break;
        }
        tlm_decoder_feed(&link->decoder, buf, n, &sink);
    }
    if (link->health_polls != 0u && --link->health_polls == 0u) {
        send_health(link);
    }
}

static void service_start(void *ctx, struct tof_app *app) {
    struct tof_link *link = ctx;
    tof_link_bind(link, app);
    /* the settings in force: their process noise is what `save` keeps until a command */
    if (link->storage == NULL) {
        /* no record: the configuration's settings and its own calibration (uncalibrated
         * unless it says), whatever was in force before (a soft restart, a reused rig) */
        tof_settings_capture(app, NULL, &link->process_noise);
        (void)tof_app_set_calibration(app, &app->cfg.estimator.calibration);
        tof_link_send_status(link);
        return;
    }
    link->record_state =
        (uint8_t)link->storage->settings_boot(link->records, app, &link->process_noise);
    if (link->cal_age != NULL) {
        /* the stored calibration's age (tof_cal_age_boot(), before the application's timeline
         * started): the calibration's boot below restarts the estimator with it */
        const uint64_t now_us = tof_app_now_us(app);
        const uint32_t age_s = link->storage->age_now_s(link->cal_age, now_us);
        (void)tof_app_set_calibration_age(app, age_s, false);
    }
    link->cal_state = (uint8_t)link->storage->cal_boot(link->records, app); /* the head's */
    tof_link_send_status(link);
}

static void service_poll(void *ctx) {
    tof_link_poll(ctx);
}

const struct tof_app_service_ops tof_link_service_ops = {.start = service_start,
                                                         .poll = service_poll};
