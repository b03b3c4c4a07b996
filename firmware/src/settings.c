/* The user's settings: captured from the application, kept in the record's settings section,
 * applied at boot (firmware/settings.h). */
#include "firmware/settings.h"

#include <stddef.h>
#include <string.h>

#include "hal/hal_err.h"

#include "telemetry/tlm_messages.h"
#include "le_bytes.h"

/* The status frame carries enum tof_record_state as it is (link.c). */
_Static_assert(TOF_RECORD_NONE == (int)TLM_RECORD_NONE &&
                   TOF_RECORD_LOADED == (int)TLM_RECORD_LOADED &&
                   TOF_RECORD_CORRUPT == (int)TLM_RECORD_CORRUPT &&
                   TOF_RECORD_VERSION == (int)TLM_RECORD_VERSION &&
                   TOF_RECORD_REJECTED == (int)TLM_RECORD_REJECTED &&
                   TOF_RECORD_NO_STORAGE == (int)TLM_RECORD_NO_STORAGE,
               "record states are the status frame's codes");

#define SECTION_HEADER TOF_SECTION_HEADER
#define FLAG_PN_SET    0x01u
#define FLAG_PN_AUTO   0x02u

void tof_settings_capture(const struct tof_app *app, const struct tof_settings *pn,
                          struct tof_settings *out) {
    struct tof_app_status st;
    tof_app_get_status(app, &st);
    *out = (struct tof_settings){
        .window = st.window,
        .sliding = st.sliding,
        .primary = (uint8_t)st.primary,
        .running = st.running,
        .raw_output = st.raw_output,
        .arm_um = st.arm_um,
        .period_ms = (uint16_t)(st.period_us / 1000u),
    };
    if (pn != NULL && pn->process_noise_set) {
        out->process_noise_set = true;
        out->process_noise_auto = pn->process_noise_auto;
        out->qd_um2_per_s = pn->qd_um2_per_s;
        out->qt_um2_per_s = pn->qt_um2_per_s;
    }
}

int tof_settings_apply(struct tof_app *app, const struct tof_settings *s) {
    struct tof_app_status st;
    tof_app_get_status(app, &st);
    int rc = 0;
    /* the rate first: it restarts the sensors and rescales Q; then what the estimators take */
    if (s->period_ms != 0u && (uint32_t)s->period_ms * 1000u != st.period_us) {
        rc = tof_app_set_period(app, s->period_ms);
    }
    if (rc == 0 && s->arm_um != 0) {
        rc = tof_app_set_arm(app, s->arm_um);
    }
    if (rc == 0) {
        rc = tof_app_set_window(app, s->window, s->sliding);
    }
    if (rc == 0 && s->process_noise_set) {
        rc =
            tof_app_set_process_noise(app, s->qd_um2_per_s, s->qt_um2_per_s, s->process_noise_auto);
    }
    if (rc == 0) {
        rc = tof_app_set_primary(app, (enum attitude_estimator)s->primary);
    }
    if (rc == 0) {
        tof_app_set_running(app, s->running);
        tof_app_set_raw_output(app, s->raw_output);
    }
    return rc;
}

int tof_section_find(const uint8_t *payload, uint16_t len, uint8_t id) {
    uint32_t at = 0;
    /* each section takes >= TOF_SECTION_HEADER bytes: at most len / 4 of them */
    for (uint32_t n = 0; n <= TOF_RECORD_PAYLOAD_MAX / TOF_SECTION_HEADER && at < len; ++n) {
        if (len - at < TOF_SECTION_HEADER) {
            return -2;
        }
        const uint32_t size = (uint32_t)payload[at + 2u] | (uint32_t)payload[at + 3u] << 8;
        if (size > len - at - TOF_SECTION_HEADER) {
            return -2;
        }
        if (payload[at] == id) {
            return (int)at;
        }
        at += TOF_SECTION_HEADER + size;
    }
    return at == len ? -1 : -2;
}

enum tof_record_state tof_settings_decode(const uint8_t *payload, uint16_t len,
                                          struct tof_settings *out) {
    const int at = tof_section_find(payload, len, TOF_SECTION_SETTINGS);
    if (at < 0) {
        return at == -1 ? TOF_RECORD_NONE : TOF_RECORD_CORRUPT;
    }
    const uint8_t *p = &payload[at];
    const uint16_t size = (uint16_t)(p[2] | p[3] << 8);
    if (p[1] != TOF_SETTINGS_VERSION && p[1] != 1u) {
        return TOF_RECORD_VERSION;
    }
    const uint8_t *v = &p[SECTION_HEADER];
    const bool v2 = p[1] == TOF_SETTINGS_VERSION;
    if (size != (v2 ? TOF_SETTINGS_LENGTH : TOF_SETTINGS_V1_LENGTH) ||
        (v2 && (v[22] != 0u || v[23] != 0u)) || v[2] > 1u || v[4] > 1u || v[5] > 1u ||
        (v[6] & ~(FLAG_PN_SET | FLAG_PN_AUTO)) != 0u || v[7] != 0u) {
        return TOF_RECORD_CORRUPT;
    }
    *out = (struct tof_settings){
        .window = (uint16_t)(v[0] | v[1] << 8),
        .sliding = v[2] == 1u,
        .primary = v[3],
        .running = v[4] == 1u,
        .raw_output = v[5] == 1u,
        .process_noise_set = (v[6] & FLAG_PN_SET) != 0u,
        .process_noise_auto = (v[6] & FLAG_PN_AUTO) != 0u,
        .qd_um2_per_s = le_get_u32(&v[8]),
        .qt_um2_per_s = le_get_u32(&v[12]),
        .arm_um = v2 ? (int32_t)le_get_u32(&v[16]) : 0,
        .period_ms = (uint16_t)(v2 ? (v[20] | v[21] << 8) : 0),
    };
    return TOF_RECORD_LOADED;
}

enum tof_record_state tof_settings_boot(struct tof_record_store *store, struct tof_app *app,
                                        struct tof_settings *out) {
    struct tof_settings defaults;
    tof_settings_capture(app, NULL, &defaults);
    *out = defaults;
    if (store == NULL || store->storage.ops == NULL) {
        return TOF_RECORD_NO_STORAGE;
    }
    enum tof_record_state state = tof_record_load(store);
    struct tof_settings saved;
    if (state == TOF_RECORD_LOADED) {
        state = tof_settings_decode(store->payload, store->length, &saved);
    }
    if (state != TOF_RECORD_LOADED) {
        return state;
    }
    if (tof_settings_apply(app, &saved) != 0) {
        (void)tof_settings_apply(app, &defaults); /* they ran at init: accepted again */
        return TOF_RECORD_REJECTED;
    }
    *out = saved;
    return TOF_RECORD_LOADED;
}

/* The settings section of `s` into `out` (SECTION_HEADER + TOF_SETTINGS_LENGTH bytes). */
static void encode(const struct tof_settings *s, uint8_t *out) {
    memset(out, 0, SECTION_HEADER + TOF_SETTINGS_LENGTH);
    out[0] = TOF_SECTION_SETTINGS;
    out[1] = TOF_SETTINGS_VERSION;
    out[2] = TOF_SETTINGS_LENGTH;
    uint8_t *v = &out[SECTION_HEADER];
    v[0] = (uint8_t)s->window;
    v[1] = (uint8_t)(s->window >> 8);
    v[2] = s->sliding ? 1u : 0u;
    v[3] = s->primary;
    v[4] = s->running ? 1u : 0u;
    v[5] = s->raw_output ? 1u : 0u;
    v[6] = (uint8_t)((s->process_noise_set ? FLAG_PN_SET : 0u) |
                     (s->process_noise_auto ? FLAG_PN_AUTO : 0u));
    le_put_u32(&v[8], s->qd_um2_per_s);
    le_put_u32(&v[12], s->qt_um2_per_s);
    le_put_u32(&v[16], (uint32_t)s->arm_um);
    v[20] = (uint8_t)s->period_ms;
    v[21] = (uint8_t)(s->period_ms >> 8);
}

/* The record's new payload (off the stack: the main loop's frame is the deepest). */
static uint8_t save_payload[TOF_RECORD_PAYLOAD_MAX];

/* The record's new payload with `section` (id, version, length, bytes) in `payload`: its
 * length, or 0 and *rc. */
static uint32_t new_payload(const struct tof_record_store *store, const uint8_t *section,
                            uint8_t *payload, int *rc) {
    /* The new payload: this section first, then every other section of the record in use,
     * as it was (a damaged list is dropped: nothing of it can be trusted). */
    uint32_t len = SECTION_HEADER + (uint32_t)(section[2] | section[3] << 8);
    if (len > TOF_RECORD_PAYLOAD_MAX) {
        *rc = HAL_ERR_INVALID;
        return 0u;
    }
    memcpy(payload, section, len);
    const uint8_t *old = store->payload;
    const uint16_t old_len = store->current >= 0 ? store->length : 0u;
    if (tof_section_find(old, old_len, 0u) == -1 /* the list adds up */) {
        for (uint32_t at = 0, n = 0; at < old_len && n < TOF_RECORD_PAYLOAD_MAX; ++n) {
            const uint32_t size = SECTION_HEADER + (uint32_t)(old[at + 2u] | old[at + 3u] << 8);
            if (old[at] != section[0]) {
                if (len + size > TOF_RECORD_PAYLOAD_MAX) {
                    *rc = HAL_ERR_INVALID;
                    return 0u;
                }
                memcpy(&payload[len], &old[at], size);
                len += size;
            }
            at += size;
        }
    }
    *rc = HAL_OK;
    return len;
}

int tof_section_save(struct tof_record_store *store, const uint8_t *section) {
    if (store == NULL || store->storage.ops == NULL) {
        return HAL_ERR_STATE;
    }
    int rc = HAL_OK;
    const uint32_t len = new_payload(store, section, save_payload, &rc);
    return rc != HAL_OK ? rc : tof_record_save_in_use(store, save_payload, (uint16_t)len);
}

int tof_settings_save(struct tof_record_store *store, const struct tof_settings *s) {
    uint8_t section[SECTION_HEADER + TOF_SETTINGS_LENGTH];
    encode(s, section);
    return tof_section_save(store, section);
}

int tof_settings_save_begin(struct tof_record_store *store, const struct tof_settings *s) {
    if (store == NULL || store->storage.ops == NULL) {
        return HAL_ERR_STATE;
    }
    uint8_t section[SECTION_HEADER + TOF_SETTINGS_LENGTH];
    encode(s, section);
    int rc = HAL_OK;
    const uint32_t len = new_payload(store, section, save_payload, &rc);
    return rc != HAL_OK ? rc : tof_record_save_begin(store, save_payload, (uint16_t)len);
}
