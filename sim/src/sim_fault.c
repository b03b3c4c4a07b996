/* Fault-injection settings of the simulated bus: names, parsing and validation
 * (sim/sim_fault.h). */
#include "sim/sim_fault.h"

static const char *const fault_names[SIM_FAULT_COUNT] = {
    [SIM_FAULT_NACK] = "nack",         [SIM_FAULT_STRETCH] = "stretch",
    [SIM_FAULT_RESET] = "reset",       [SIM_FAULT_DRDY_HIGH] = "drdy_high",
    [SIM_FAULT_DRDY_LOW] = "drdy_low", [SIM_FAULT_GARBAGE] = "garbage",
    [SIM_FAULT_BITFLIP] = "bitflip",   [SIM_FAULT_STUCK] = "stuck",
};

const char *sim_fault_name(enum sim_fault_kind kind) {
    if ((unsigned)kind >= (unsigned)SIM_FAULT_COUNT) {
        return "?";
    }
    return fault_names[kind];
}

int sim_fault_kind_from_name(const char *name, size_t len) {
    for (int kind = 0; kind < (int)SIM_FAULT_COUNT; ++kind) {
        const char *candidate = fault_names[kind];
        size_t i = 0;
        while (i < len && candidate[i] != '\0' && candidate[i] == name[i]) {
            ++i;
        }
        if (i == len && candidate[i] == '\0') {
            return kind;
        }
    }
    return -1;
}

static int fail(size_t at, const char *what, size_t *error_at, const char **error_what) {
    if (error_at != NULL) {
        *error_at = at;
    }
    if (error_what != NULL) {
        *error_what = what;
    }
    return -1;
}

/* Parse a probability at spec[*pos] into ppm: "0", "1", "0.25", "1.0", ".5" (<= 6 decimals). */
static int parse_ppm(const char *spec, size_t *pos, uint32_t *ppm, size_t *error_at,
                     const char **error_what) {
    size_t i = *pos;
    uint32_t whole = 0u;
    uint32_t fraction = 0u;
    unsigned whole_digits = 0u;
    unsigned fraction_digits = 0u;
    while (spec[i] >= '0' && spec[i] <= '9') {
        if (whole_digits >= 2u) {
            return fail(i, "probability above 1", error_at, error_what);
        }
        whole = whole * 10u + (uint32_t)(spec[i] - '0');
        ++whole_digits;
        ++i;
    }
    if (spec[i] == '.') {
        ++i;
        while (spec[i] >= '0' && spec[i] <= '9') {
            if (fraction_digits >= 6u) {
                return fail(i, "more than 6 decimals (finer than 1 ppm)", error_at, error_what);
            }
            fraction = fraction * 10u + (uint32_t)(spec[i] - '0');
            ++fraction_digits;
            ++i;
        }
    }
    if (whole_digits == 0u && fraction_digits == 0u) {
        return fail(i, "expected a probability such as 0.01", error_at, error_what);
    }
    for (unsigned d = fraction_digits; d < 6u; ++d) {
        fraction *= 10u;
    }
    uint32_t value = whole * SIM_PPM_ONE + fraction;
    if (value > SIM_PPM_ONE) {
        return fail(*pos, "probability above 1", error_at, error_what);
    }
    *ppm = value;
    *pos = i;
    return 0;
}

int sim_fault_parse(const char *spec, struct sim_fault_config *out, size_t *error_at,
                    const char **error_what) {
    if (spec == NULL || out == NULL) {
        return fail(0u, "no fault specification", error_at, error_what);
    }
    uint32_t ppm[SIM_FAULT_COUNT] = {0};
    size_t pos = 0u;
    /* Each item consumes at least one character, so the loop is bounded by the text. */
    while (spec[pos] != '\0') {
        size_t name_start = pos;
        while (spec[pos] != '\0' && spec[pos] != '=' && spec[pos] != ',') {
            ++pos;
        }
        int kind = sim_fault_kind_from_name(&spec[name_start], pos - name_start);
        if (kind < 0) {
            return fail(name_start,
                        "unknown fault kind (nack, stretch, reset, drdy_high, drdy_low, "
                        "garbage, bitflip, stuck)",
                        error_at, error_what);
        }
        if (spec[pos] != '=') {
            return fail(pos, "expected '=' after the fault kind", error_at, error_what);
        }
        ++pos;
        if (parse_ppm(spec, &pos, &ppm[kind], error_at, error_what) != 0) {
            return -1;
        }
        if (spec[pos] == ',') {
            ++pos;
            if (spec[pos] == '\0') {
                return fail(pos, "trailing ','", error_at, error_what);
            }
        } else if (spec[pos] != '\0') {
            return fail(pos, "expected ',' or the end after the probability", error_at, error_what);
        }
    }
    for (unsigned kind = 0; kind < (unsigned)SIM_FAULT_COUNT; ++kind) {
        out->ppm[kind] = ppm[kind];
    }
    return 0;
}
