/* Sensor-array bring-up and recovery over the VL53 driver. */
/*
 * Every sensor powers up at 0x29, so only one may be out of reset while it is at that address; the
 * checks below make sure of it before each release instead of assuming it.
 */
#include "vl53_array/vl53_array.h"

#include "hal/hal_err.h"
#include "hal/hal_i2c_reg.h"

static bool index_ok(const struct vl53_array *array, size_t index) {
    return array != NULL && array->cfg != NULL && index < array->cfg->count;
}

int vl53_array_attach(struct vl53_array *array, const struct vl53_array_config *cfg) {
    if (array == NULL || cfg == NULL || cfg->sensors == NULL || cfg->count == 0u ||
        cfg->count > VL53_ARRAY_MAX_SENSORS) {
        return HAL_ERR_INVALID;
    }
    for (size_t i = 0; i < cfg->count; ++i) {
        const struct vl53_config *s = &cfg->sensors[i];
        if (vl53_config_check(s) != NULL || s->address == VL53_DEFAULT_ADDRESS ||
            s->xshut_pin == VL53_PIN_NONE || s->i2c.ops != cfg->sensors[0].i2c.ops ||
            s->i2c.ctx != cfg->sensors[0].i2c.ctx) {
            return HAL_ERR_INVALID;
        }
        for (size_t j = 0; j < i; ++j) {
            if (cfg->sensors[j].address == s->address ||
                cfg->sensors[j].xshut_pin == s->xshut_pin) {
                return HAL_ERR_INVALID;
            }
        }
    }
    array->cfg = cfg;
    for (size_t i = 0; i < cfg->count; ++i) {
        int err = vl53_attach(&array->dev[i], &cfg->sensors[i]);
        if (err != HAL_OK) {
            return err;
        }
        struct vl53_sensor_report fresh = {VL53_SENSOR_OFF, VL53_ARRAY_OK, HAL_OK, 0u, 0u};
        array->report[i] = fresh;
    }
    return HAL_OK;
}

/* Does anything answer at `addr`? HAL_OK if so, HAL_ERR_ADDR_NACK if not, else a bus error. */
static int probe(const struct vl53_array *array, uint8_t addr) {
    const struct vl53_config *any = &array->cfg->sensors[0];
    uint32_t timeout =
        any->i2c_timeout_us != 0u ? any->i2c_timeout_us : VL53_DEFAULT_I2C_TIMEOUT_US;
    uint8_t id[2];
    return hal_i2c_reg16_read(&any->i2c, addr, VL53_REG_IDENTIFICATION_MODEL_ID, id, sizeof id,
                              timeout);
}

static void wait_xshut_low(const struct vl53_array *array) {
    const struct hal_time *time = &array->cfg->sensors[0].time;
    time->ops->delay_us(time->ctx, VL53_ARRAY_XSHUT_LOW_US);
}

/* Record a failure, park the sensor in reset (so it cannot collide at 0x29 later) and
 * return the error unchanged. A failing XSHUT write cannot be reported better than `err`. */
static int fail(struct vl53_array *array, size_t index, enum vl53_array_fault fault, int err,
                uint8_t conflict_address) {
    struct vl53_sensor_report *report = &array->report[index];
    (void)vl53_shutdown(&array->dev[index]);
    report->state = VL53_SENSOR_OFF;
    report->fault = fault;
    report->err = err;
    report->conflict_address = conflict_address;
    return err;
}

/* `addr` must be free while this sensor is in reset: HAL_OK, or the failure recorded. */
static int require_free(struct vl53_array *array, size_t index, uint8_t addr) {
    int err = probe(array, addr);
    if (err == HAL_ERR_ADDR_NACK) {
        return HAL_OK;
    }
    if (err == HAL_OK) {
        return fail(array, index, VL53_ARRAY_ADDRESS_CONFLICT, HAL_ERR_STATE, addr);
    }
    return fail(array, index, VL53_ARRAY_BUS_ERROR, err, addr);
}

/* Every other sensor that is up (ranging, or configuring: moved to its address) must still
 * answer at its own address. A sensor that reset while this one was at 0x29 (silent in its
 * early boot when 0x29 was probed) took the address write too and now answers at this
 * one's address as well: its reads would be wired-AND with ours, undetectably. It lost its
 * own address to do so, which is what this looks for (read-only probes: undisturbed). */
static int check_others(struct vl53_array *array, size_t index) {
    const uint8_t target = array->cfg->sensors[index].address;
    for (size_t j = 0; j < array->cfg->count; ++j) {
        const enum vl53_sensor_state state = array->report[j].state;
        if (j == index || state == VL53_SENSOR_OFF) {
            continue;
        }
        int err = probe(array, array->cfg->sensors[j].address);
        if (err == HAL_ERR_ADDR_NACK) {
            return fail(array, index, VL53_ARRAY_ADDRESS_CONFLICT, HAL_ERR_STATE, target);
        }
        if (err != HAL_OK) {
            return fail(array, index, VL53_ARRAY_BUS_ERROR, err, target);
        }
    }
    return HAL_OK;
}

/* Release one sensor (held in reset, 0x29 and its address checked free), move it to its
 * address and start its VHV range (vl53_configure_begin): CONFIGURING on success. */
static int release_and_begin(struct vl53_array *array, size_t index) {
    struct vl53_dev *dev = &array->dev[index];
    struct vl53_sensor_report *report = &array->report[index];
    const uint8_t target = array->cfg->sensors[index].address;
    int err = vl53_power_up(dev);
    if (err != HAL_OK) {
        return fail(array, index, VL53_ARRAY_BUS_ERROR, err, 0u);
    }
    err = vl53_wait_boot(dev);
    if (err == HAL_ERR_ADDR_NACK) {
        return fail(array, index, VL53_ARRAY_MISSING, err, VL53_DEFAULT_ADDRESS);
    }
    if (err == HAL_ERR_TIMEOUT) {
        return fail(array, index, VL53_ARRAY_BOOT_TIMEOUT, err, VL53_DEFAULT_ADDRESS);
    }
    if (err != HAL_OK) {
        return fail(array, index, VL53_ARRAY_BUS_ERROR, err, VL53_DEFAULT_ADDRESS);
    }
    err = vl53_identify(dev, &report->model_id);
    if (err != HAL_OK) {
        return fail(array, index,
                    err == HAL_ERR_ID_MISMATCH ? VL53_ARRAY_WRONG_ID : VL53_ARRAY_BUS_ERROR, err,
                    VL53_DEFAULT_ADDRESS);
    }
    err = vl53_set_address(dev, target);
    if (err != HAL_OK) {
        /* Not confirmed at its new address: if it still answers at 0x29, it ignored the move. */
        bool still_default = probe(array, VL53_DEFAULT_ADDRESS) == HAL_OK;
        return fail(array, index,
                    still_default ? VL53_ARRAY_STUCK_AT_DEFAULT : VL53_ARRAY_BUS_ERROR, err,
                    still_default ? VL53_DEFAULT_ADDRESS : target);
    }
    err = probe(array, VL53_DEFAULT_ADDRESS);
    if (err == HAL_OK) {
        /* It moved, yet 0x29 still answers: a second device came out of reset with it. */
        return fail(array, index, VL53_ARRAY_ADDRESS_CONFLICT, HAL_ERR_STATE, VL53_DEFAULT_ADDRESS);
    }
    if (err != HAL_ERR_ADDR_NACK) {
        return fail(array, index, VL53_ARRAY_BUS_ERROR, err, VL53_DEFAULT_ADDRESS);
    }
    err = vl53_read_part_id(dev, NULL); /* the part's own identity, before ST's block */
    if (err != HAL_OK) {
        return fail(array, index, VL53_ARRAY_IDENTITY_FAILED, err, target);
    }
    err = vl53_configure_begin(dev);
    if (err != HAL_OK) {
        return fail(array, index, VL53_ARRAY_CONFIG_FAILED, err, target);
    }
    err = check_others(array, index);
    if (err != HAL_OK) {
        return err;
    }
    report->state = VL53_SENSOR_CONFIGURING;
    return HAL_OK;
}

/* A CONFIGURING sensor: end its VHV step, write its timing, start it: RANGING on success. */
static int finish_and_start(struct vl53_array *array, size_t index) {
    struct vl53_dev *dev = &array->dev[index];
    struct vl53_sensor_report *report = &array->report[index];
    int err = vl53_configure_finish(dev);
    if (err == HAL_OK) {
        err = vl53_start_ranging(dev);
    }
    if (err != HAL_OK) {
        return fail(array, index, VL53_ARRAY_CONFIG_FAILED, err,
                    array->cfg->sensors[index].address);
    }
    report->state = VL53_SENSOR_RANGING;
    report->fault = VL53_ARRAY_OK;
    report->err = HAL_OK;
    report->conflict_address = 0u;
    return HAL_OK;
}

int vl53_array_bring_up(struct vl53_array *array) {
    if (array == NULL || array->cfg == NULL) {
        return HAL_ERR_INVALID;
    }
    const size_t count = array->cfg->count;
    int first_err = HAL_OK;
    bool skip[VL53_ARRAY_MAX_SENSORS]; /* read only below `count`, each set here first */
    for (size_t i = 0; i < count; ++i) {
        struct vl53_sensor_report fresh = {VL53_SENSOR_OFF, VL53_ARRAY_OK, HAL_OK, 0u, 0u};
        array->report[i] = fresh;
        skip[i] = false;
        int err = vl53_shutdown(&array->dev[i]);
        if (err != HAL_OK) {
            (void)fail(array, i, VL53_ARRAY_BUS_ERROR, err, 0u);
            skip[i] = true;
            first_err = first_err != HAL_OK ? first_err : err;
        }
    }
    wait_xshut_low(array);
    /* With every sensor in reset nothing may answer at 0x29: a part whose XSHUT does not
     * work (or another device) would collide with each sensor we release. */
    int err = probe(array, VL53_DEFAULT_ADDRESS);
    if (err == HAL_ERR_BUS_STUCK && vl53_array_recover_bus(array) == HAL_OK) {
        err = probe(array, VL53_DEFAULT_ADDRESS);
    }
    if (err != HAL_ERR_ADDR_NACK) {
        enum vl53_array_fault fault =
            err == HAL_OK ? VL53_ARRAY_ADDRESS_CONFLICT : VL53_ARRAY_BUS_ERROR;
        int code = err == HAL_OK ? HAL_ERR_STATE : err;
        for (size_t i = 0; i < count; ++i) {
            (void)fail(array, i, fault, code, VL53_DEFAULT_ADDRESS);
        }
        return code;
    }
    /* Nor at any sensor's own address (e.g. a part that kept it through an MCU reset). */
    for (size_t i = 0; i < count; ++i) {
        if (!skip[i] && require_free(array, i, array->cfg->sensors[i].address) != HAL_OK) {
            skip[i] = true;
            first_err = first_err != HAL_OK ? first_err : array->report[i].err;
        }
    }
    /* Each sensor's VHV range takes ~100 ms at the block's timing: release and begin them
     * one after the other (only one may be at 0x29 at a time), so the four ranges overlap,
     * then finish each. */
    for (size_t i = 0; i < count; ++i) {
        if (skip[i]) {
            continue;
        }
        err = require_free(array, i, VL53_DEFAULT_ADDRESS);
        if (err == HAL_OK) {
            err = release_and_begin(array, i);
        }
        if (err != HAL_OK && first_err == HAL_OK) {
            first_err = err;
        }
    }
    for (size_t i = 0; i < count; ++i) {
        if (array->report[i].state != VL53_SENSOR_CONFIGURING) {
            continue;
        }
        err = finish_and_start(array, i);
        if (err != HAL_OK && first_err == HAL_OK) {
            first_err = err;
        }
    }
    return first_err;
}

int vl53_array_recover_sensor_begin(struct vl53_array *array, size_t index) {
    if (!index_ok(array, index)) {
        return HAL_ERR_INVALID;
    }
    struct vl53_dev *dev = &array->dev[index];
    int err = vl53_shutdown(dev);
    if (err != HAL_OK) {
        return fail(array, index, VL53_ARRAY_BUS_ERROR, err, 0u);
    }
    array->report[index].state = VL53_SENSOR_OFF;
    wait_xshut_low(array);
    err = require_free(array, index, VL53_DEFAULT_ADDRESS);
    if (err == HAL_OK) {
        err = require_free(array, index, array->cfg->sensors[index].address);
    }
    if (err == HAL_OK) {
        err = release_and_begin(array, index);
    }
    return err;
}

int vl53_array_recover_sensor_step(struct vl53_array *array, size_t index) {
    if (!index_ok(array, index)) {
        return HAL_ERR_INVALID;
    }
    if (array->report[index].state != VL53_SENSOR_CONFIGURING) {
        return HAL_ERR_STATE;
    }
    int err = vl53_configure_pending(&array->dev[index]);
    if (err == HAL_OK) {
        return finish_and_start(array, index); /* data ready: no waiting */
    }
    if (err == HAL_ERR_TIMEOUT || err == HAL_ERR_BUS_STUCK) {
        return fail(array, index, VL53_ARRAY_CONFIG_FAILED, err,
                    array->cfg->sensors[index].address);
    }
    return HAL_ERR_NOT_READY; /* still ranging, or one look lost to the bus: look again */
}

int vl53_array_recover_sensor(struct vl53_array *array, size_t index) {
    int err = vl53_array_recover_sensor_begin(array, index);
    if (err == HAL_OK) {
        err = finish_and_start(array, index);
    }
    return err;
}

int vl53_array_recover_bus(struct vl53_array *array) {
    if (array == NULL || array->cfg == NULL) {
        return HAL_ERR_INVALID;
    }
    const struct hal_i2c *bus = &array->cfg->sensors[0].i2c;
    if (bus->ops->recover == NULL) {
        return HAL_ERR_INVALID;
    }
    return bus->ops->recover(bus->ctx);
}

static uint32_t value_or(uint32_t value, uint32_t fallback) {
    return value != 0u ? value : fallback;
}

/* Release, boot, identify, move, probe 0x29, NVM identity (four budgets), configure (begin
 * and finish), start: one
 * sensor's bring-up. */
static uint32_t release_budget_us(const struct vl53_config *cfg) {
    uint32_t call = vl53_call_budget_us(cfg);
    uint32_t transfer = value_or(cfg->i2c_timeout_us, VL53_DEFAULT_I2C_TIMEOUT_US);
    return VL53_BOOT_TIME_MAX_US + VL53_BOOT_SLACK_US + VL53_BOOT_POLL_US + 8u * call + transfer +
           value_or(cfg->configure_budget_us, VL53_DEFAULT_CONFIGURE_BUDGET_US);
}

uint32_t vl53_array_recover_budget_us(const struct vl53_array *array, size_t index) {
    if (!index_ok(array, index)) {
        return 0u;
    }
    const struct vl53_config *cfg = &array->cfg->sensors[index];
    uint32_t transfer = value_or(cfg->i2c_timeout_us, VL53_DEFAULT_I2C_TIMEOUT_US);
    /* Probes of 0x29 and its address before, of the others' addresses after. */
    uint32_t probes = 2u + (uint32_t)array->cfg->count - 1u;
    return VL53_ARRAY_XSHUT_LOW_US + probes * transfer + release_budget_us(cfg);
}

uint32_t vl53_array_bring_up_budget_us(const struct vl53_array *array) {
    if (array == NULL || array->cfg == NULL) {
        return 0u;
    }
    const struct vl53_config *first = &array->cfg->sensors[0];
    uint32_t transfer = value_or(first->i2c_timeout_us, VL53_DEFAULT_I2C_TIMEOUT_US);
    /* Two probes of 0x29 around a bus recovery, then one per sensor address. */
    uint32_t total = VL53_ARRAY_XSHUT_LOW_US + (2u + (uint32_t)array->cfg->count) * transfer;
    for (size_t i = 0; i < array->cfg->count; ++i) {
        /* Probe of 0x29 before the release, the release, probes of the sensors up before. */
        total += (1u + (uint32_t)i) * transfer + release_budget_us(&array->cfg->sensors[i]);
    }
    return total;
}

int vl53_array_poll(struct vl53_array *array, size_t index, struct vl53_result *result) {
    if (!index_ok(array, index)) {
        return HAL_ERR_INVALID;
    }
    return vl53_poll(&array->dev[index], result);
}

struct vl53_dev *vl53_array_sensor(struct vl53_array *array, size_t index) {
    return index_ok(array, index) ? &array->dev[index] : NULL;
}

const struct vl53_sensor_report *vl53_array_report(const struct vl53_array *array, size_t index) {
    return index_ok(array, index) ? &array->report[index] : NULL;
}

size_t vl53_array_ranging_count(const struct vl53_array *array) {
    size_t ranging = 0u;
    for (size_t i = 0; array != NULL && array->cfg != NULL && i < array->cfg->count; ++i) {
        if (array->report[i].state == VL53_SENSOR_RANGING && vl53_is_ranging(&array->dev[i])) {
            ranging++;
        }
    }
    return ranging;
}

const char *vl53_array_fault_name(enum vl53_array_fault fault) {
    switch (fault) {
    case VL53_ARRAY_OK:
        return "ok";
    case VL53_ARRAY_MISSING:
        return "missing";
    case VL53_ARRAY_BOOT_TIMEOUT:
        return "boot_timeout";
    case VL53_ARRAY_WRONG_ID:
        return "wrong_id";
    case VL53_ARRAY_STUCK_AT_DEFAULT:
        return "stuck_at_default";
    case VL53_ARRAY_ADDRESS_CONFLICT:
        return "address_conflict";
    case VL53_ARRAY_BUS_ERROR:
        return "bus_error";
    case VL53_ARRAY_CONFIG_FAILED:
        return "config_failed";
    case VL53_ARRAY_IDENTITY_FAILED:
        return "identity_failed";
    default:
        return "unknown";
    }
}
