/* The fault manager's per-sensor health state machine (firmware/health.h). */
#include "firmware/health.h"

static void enter(struct tof_health *h, enum tof_health_state state, uint32_t now_ms) {
    if (h->state != state) {
        h->state = state;
        h->state_since_ms = now_ms;
        ++h->transitions;
        if (state == TOF_HEALTH_LOST) {
            ++h->losses;
            h->next_reinit_ms = now_ms; /* first attempt at once */
            h->in_trouble = false;      /* the re-init starts afresh */
        }
    }
}

void tof_health_init(struct tof_health *h, uint32_t now_ms) {
    *h = (struct tof_health){
        .state = TOF_HEALTH_HEALTHY, .last_good_ms = now_ms, .state_since_ms = now_ms};
}

void tof_health_on_good(struct tof_health *h, const struct tof_health_config *cfg,
                        uint32_t now_ms) {
    h->consecutive_errors = 0;
    h->last_good_ms = now_ms;
    if (h->consecutive_good < UINT8_MAX) {
        ++h->consecutive_good;
    }
    switch (h->state) {
    case TOF_HEALTH_RECOVERING:
        enter(h, TOF_HEALTH_HEALTHY, now_ms); /* first good reading after re-init */
        break;
    case TOF_HEALTH_SUSPECT:
        if (h->consecutive_good >= cfg->good_to_healthy) {
            enter(h, TOF_HEALTH_HEALTHY, now_ms);
        }
        break;
    case TOF_HEALTH_LOST: /* a LOST sensor is not read; a stray good reading changes nothing */
    case TOF_HEALTH_HEALTHY:
    default:
        break;
    }
}

/* A sensor error joins the current episode of trouble or starts one. */
static void note_trouble(struct tof_health *h, const struct tof_health_config *cfg,
                         uint32_t now_ms) {
    if (h->in_trouble && now_ms - h->last_error_ms > cfg->suspect_timeout_ms) {
        h->in_trouble = false; /* a clean stretch ended the episode before this error */
    }
    h->last_error_ms = now_ms;
    if (!h->in_trouble) {
        h->in_trouble = true;
        h->trouble_since_ms = now_ms;
        h->trouble_error_count = 0;
    }
    if (h->trouble_error_count < UINT8_MAX) {
        ++h->trouble_error_count;
    }
}

void tof_health_on_error(struct tof_health *h, const struct tof_health_config *cfg, uint32_t now_ms,
                         enum tof_error_scope scope) {
    h->consecutive_good = 0;
    if (h->consecutive_errors < UINT8_MAX) {
        ++h->consecutive_errors;
    }
    if (scope != TOF_ERROR_BUS) {
        note_trouble(h, cfg, now_ms);
    }
    if (scope == TOF_ERROR_DEVICE) {
        enter(h, TOF_HEALTH_LOST, now_ms); /* only a re-init can clear it */
        return;
    }
    switch (h->state) {
    case TOF_HEALTH_HEALTHY:
        enter(h,
              h->consecutive_errors >= cfg->errors_to_lost ? TOF_HEALTH_LOST : TOF_HEALTH_SUSPECT,
              now_ms);
        break;
    case TOF_HEALTH_SUSPECT:
    case TOF_HEALTH_RECOVERING:
        if (h->consecutive_errors >= cfg->errors_to_lost) {
            enter(h, TOF_HEALTH_LOST, now_ms);
        }
        break;
    case TOF_HEALTH_LOST:
    default:
        break;
    }
}

void tof_health_on_reinit_done(struct tof_health *h, const struct tof_health_config *cfg,
                               uint32_t now_ms, bool ok) {
    h->consecutive_errors = 0;
    h->consecutive_good = 0;
    if (ok) {
        enter(h, TOF_HEALTH_RECOVERING, now_ms);
        h->last_good_ms = now_ms;
    } else {
        /* Stay LOST; try again after the back-off. */
        h->next_reinit_ms = now_ms + cfg->reinit_backoff_ms;
    }
}

enum tof_health_action tof_health_poll(struct tof_health *h, const struct tof_health_config *cfg,
                                       uint32_t now_ms) {
    const uint32_t silent_ms = now_ms - h->last_good_ms; /* unsigned: wrap-safe */
    const uint32_t in_state_ms = now_ms - h->state_since_ms;
    switch (h->state) {
    case TOF_HEALTH_HEALTHY:
    case TOF_HEALTH_SUSPECT:
        if (h->in_trouble && now_ms - h->last_error_ms > cfg->suspect_timeout_ms) {
            h->in_trouble = false; /* a clean stretch ends the episode */
        }
        /* the errors themselves must span the timeout: a burst followed by good readings
         * ends with the clean stretch, however long ago it began */
        if (silent_ms > cfg->silence_to_lost_ms ||
            (h->in_trouble && h->last_error_ms - h->trouble_since_ms >= cfg->suspect_timeout_ms &&
             h->trouble_error_count >= cfg->trouble_errors)) {
            enter(h, TOF_HEALTH_LOST, now_ms);
            return TOF_HEALTH_ACT_REINIT;
        }
        return TOF_HEALTH_ACT_NONE;
    case TOF_HEALTH_RECOVERING:
        if (in_state_ms > cfg->recovery_timeout_ms) {
            enter(h, TOF_HEALTH_LOST, now_ms);
            return TOF_HEALTH_ACT_REINIT;
        }
        return TOF_HEALTH_ACT_NONE;
    case TOF_HEALTH_LOST:
        /* Due when now >= next_reinit_ms, compared wrap-safely. */
        return (int32_t)(now_ms - h->next_reinit_ms) >= 0 ? TOF_HEALTH_ACT_REINIT
                                                          : TOF_HEALTH_ACT_NONE;
    default:
        return TOF_HEALTH_ACT_NONE;
    }
}

bool tof_health_usable(const struct tof_health *h) {
    return h->state != TOF_HEALTH_LOST;
}

const char *tof_health_name(enum tof_health_state state) {
    switch (state) {
    case TOF_HEALTH_HEALTHY:
        return "healthy";
    case TOF_HEALTH_SUSPECT:
        return "suspect";
    case TOF_HEALTH_LOST:
        return "lost";
    case TOF_HEALTH_RECOVERING:
        return "recovering";
    default:
        return "unknown";
    }
}

bool tof_health_config_valid(const struct tof_health_config *cfg) {
    return cfg->errors_to_lost >= 1u && cfg->good_to_healthy >= 1u &&
           cfg->silence_to_lost_ms > 0u && cfg->reinit_backoff_ms > 0u &&
           cfg->recovery_timeout_ms > 0u && cfg->suspect_timeout_ms > 0u &&
           cfg->trouble_errors >= 1u;
}
