/* The driver fuzz harness: see fuzz_vl53_harness.h. */
#include "fuzz_vl53_harness.h"

#include <string.h>

#include "fuzz_input.h"
#include "hal/hal_err.h"
#include "hal/hal_i2c_reg.h"
#include "vl53/vl53.h"
#include "vl53_array/vl53_array.h"

#define SENSORS_MAX VL53_ARRAY_MAX_SENSORS

/* Valid timings (vl53.h: ULD budgets per mode, period >= budget + 4 ms). */
static const struct vl53_timing timings[] = {
    {VL53_DISTANCE_SHORT, 15u, 20u},     {VL53_DISTANCE_SHORT, 20u, 24u},
    {VL53_DISTANCE_SHORT, 33u, 50u},     {VL53_DISTANCE_SHORT, 50u, 54u},
    {VL53_DISTANCE_SHORT, 100u, 200u},   {VL53_DISTANCE_SHORT, 200u, 204u},
    {VL53_DISTANCE_SHORT, 500u, 10000u}, {VL53_DISTANCE_LONG, 20u, 24u},
    {VL53_DISTANCE_LONG, 33u, 100u},     {VL53_DISTANCE_LONG, 50u, 54u},
    {VL53_DISTANCE_LONG, 100u, 104u},    {VL53_DISTANCE_LONG, 200u, 1000u},
    {VL53_DISTANCE_LONG, 500u, 504u},    {VL53_DISTANCE_SHORT, 15u, 10000u},
};
#define TIMINGS (sizeof timings / sizeof timings[0])

/* 0 selects the driver's default. */
static const uint32_t call_budgets[] = {0u, 200u, 1000u, 3000u, 10000u, 50000u};
static const uint32_t configure_budgets[] = {0u, 2000u, 10000u, 50000u, 200000u};
static const uint32_t i2c_timeouts[] = {0u, 100u, 500u, 2000u, 10000u};
static const uint32_t poll_intervals[] = {0u, 100u, 1000u, 5000u};
#define PICK(table, byte) ((table)[(byte) % (sizeof(table) / sizeof((table)[0]))])

/* The 91-byte vendor block: its content does not matter to the driver except the
 * interrupt polarity bit at 0x30 (vl53_regs.h). */
static uint8_t vendor_block[VL53_DEFAULT_CONFIG_LEN];

static struct {
    const struct fz_source *src;
    uint64_t now; /* true µs since the run started */
    uint32_t origin;
    /* the call being measured */
    uint32_t max_wire_us; /* wire time of its longest transfer */
    uint32_t bus_errors;  /* bit -err for each bus error injected */
    unsigned failed;      /* transfers that failed */
    bool xshut_failed;    /* a GPIO write failed: a sensor may not be in reset */
    bool recover_hook;
    size_t count;
    struct vl53_config cfg[SENSORS_MAX];
    struct vl53_array_config acfg;
    struct vl53_array array;
    bool have_stream[SENSORS_MAX]; /* the driver's last accepted stream count, before the call */
    uint8_t last_stream[SENSORS_MAX];
} fz;

static bool trace; /* FZ_TRACE set: print each operation, transfer and result */

static uint8_t next(enum fz_kind kind, const struct fz_request *req) {
    return fz.src->next(fz.src->ctx, kind, req);
}

static uint32_t now32(void) {
    return (uint32_t)(fz.origin + fz.now);
}

/* --- fakes -------------------------------------------------------------------------------- */

static uint32_t fake_now_us(void *ctx) {
    (void)ctx;
    return now32();
}

static void fake_delay_us(void *ctx, uint32_t us) {
    (void)ctx;
    fz.now += us;
}

static int inject(int err) {
    fz.failed++;
    fz.bus_errors |= 1u << (unsigned)(-err);
    return err;
}

static int fake_write_read(void *ctx, uint8_t addr7, const uint8_t *tx, size_t tx_len, uint8_t *rx,
                           size_t rx_len, uint32_t timeout_us) {
    (void)ctx;
    /* The hal_i2c contract the driver must keep. */
    FUZZ_CHECK(addr7 <= 0x7Fu);
    FUZZ_CHECK(tx_len > 0u || rx_len > 0u);
    FUZZ_CHECK(tx_len == 0u || tx != NULL);
    FUZZ_CHECK(rx_len == 0u || rx != NULL);
    FUZZ_CHECK(tx_len <= 2u + HAL_I2C_REG16_MAX_WRITE && rx_len <= 64u);
    struct fz_request req;
    memset(&req, 0, sizeof req);
    req.now_us = fz.now;
    req.addr7 = addr7;
    req.tx = tx;
    req.tx_len = tx_len;
    req.rx_len = rx_len;
    req.timeout_us = timeout_us;
    const uint8_t c = next(FZ_BUS, &req);
    if (trace) {
        fprintf(stderr, "    i2c 0x%02x reg 0x%04x tx %zu rx %zu timeout %u: bus byte 0x%02x\n",
                addr7, tx_len >= 2u ? (unsigned)(tx[0] << 8 | tx[1]) : 0u, tx_len, rx_len,
                timeout_us, c);
    }
    const uint32_t bytes = 1u + (uint32_t)tx_len + (rx_len > 0u ? 1u + (uint32_t)rx_len : 0u);
    const uint32_t wire_us = (bytes * FZ_WIRE_NS_PER_BYTE + 999u) / 1000u;
    fz.max_wire_us = wire_us > fz.max_wire_us ? wire_us : fz.max_wire_us;
    /* the hal contract: never longer than the timeout plus the wire time */
    const uint32_t waited = (uint32_t)(((uint64_t)timeout_us * (c >> 4)) / 15u);
    switch (c & 0x07u) {
    case 4:
        fz.now += wire_us;
        return inject(HAL_ERR_ADDR_NACK);
    case 5:
        fz.now += wire_us + waited;
        return inject(HAL_ERR_DATA_NACK);
    case 6:
        fz.now += wire_us + timeout_us;
        return inject(HAL_ERR_TIMEOUT);
    case 7:
        fz.now += wire_us + waited;
        return inject((c & 0x08u) != 0u ? HAL_ERR_BUS_STUCK : HAL_ERR_BUS_BUSY);
    default:
        break;
    }
    fz.now += wire_us + waited;
    for (size_t i = 0; i < rx_len; ++i) {
        req.rx_index = i;
        rx[i] = next(FZ_DATA, &req);
    }
    return HAL_OK;
}

static int fake_recover(void *ctx) {
    (void)ctx;
    struct fz_request req;
    memset(&req, 0, sizeof req);
    req.now_us = fz.now;
    req.recover = true;
    const uint8_t c = next(FZ_BUS, &req);
    fz.now += FZ_RECOVER_US;
    return (c & 1u) != 0u ? HAL_ERR_BUS_STUCK : HAL_OK;
}

static int fake_gpio_write(void *ctx, uint16_t pin, bool high) {
    (void)ctx;
    FUZZ_CHECK(pin < 2u * SENSORS_MAX);
    struct fz_request req;
    memset(&req, 0, sizeof req);
    req.now_us = fz.now;
    req.pin = pin;
    req.gpio_write = true;
    req.gpio_level = high;
    if (next(FZ_GPIO, &req) == FZ_GPIO_FAIL) {
        fz.xshut_failed = true;
        return HAL_ERR_INVALID;
    }
    return HAL_OK;
}

static int fake_gpio_read(void *ctx, uint16_t pin, bool *high) {
    (void)ctx;
    FUZZ_CHECK(pin < 2u * SENSORS_MAX && high != NULL);
    struct fz_request req;
    memset(&req, 0, sizeof req);
    req.now_us = fz.now;
    req.pin = pin;
    const uint8_t c = next(FZ_GPIO, &req);
    if (c == FZ_GPIO_FAIL) {
        return HAL_ERR_INVALID;
    }
    *high = (c & 1u) != 0u;
    return HAL_OK;
}

static const struct hal_i2c_ops i2c_ops = {fake_write_read, fake_recover};
static const struct hal_i2c_ops i2c_ops_no_recover = {fake_write_read, NULL};
static const struct hal_gpio_ops gpio_ops = {fake_gpio_write, fake_gpio_read};
static const struct hal_time_ops time_ops = {fake_now_us, fake_delay_us};

/* --- checks --------------------------------------------------------------------------------- */

static uint64_t call_start;
static uint32_t call_start32;

static void begin_call(void) {
    call_start = fz.now;
    call_start32 = now32();
    fz.max_wire_us = 0;
    fz.bus_errors = 0;
    fz.failed = 0;
    fz.xshut_failed = false;
}

static void check_bound(uint64_t bound_us, const char *what) {
    const uint64_t took = fz.now - call_start;
    if (trace) {
        fprintf(stderr, "  %s: %llu us (bound %llu), %u failed transfers\n", what,
                (unsigned long long)took, (unsigned long long)bound_us, fz.failed);
    }
    if (took > bound_us) {
        fprintf(stderr, "%s took %llu us, bound %llu us\n", what, (unsigned long long)took,
                (unsigned long long)bound_us);
    }
    FUZZ_CHECK(took <= bound_us);
}

static bool is_hal_err(int rc) {
    return rc <= HAL_OK && rc >= HAL_ERR_DEVICE;
}

/* A bus error a call returns must be one the bus gave it in this call (passed up
 * unchanged, never invented); TIMEOUT may also be the call's own budget or deadline. */
static void check_error_origin(int rc) {
    FUZZ_CHECK(is_hal_err(rc));
    if (rc == HAL_ERR_ADDR_NACK || rc == HAL_ERR_DATA_NACK || rc == HAL_ERR_BUS_BUSY ||
        rc == HAL_ERR_BUS_STUCK) {
        FUZZ_CHECK((fz.bus_errors >> (unsigned)(-rc) & 1u) != 0u);
    }
}

/* Driver calls other than wait_boot: every failed transfer makes the call fail. */
static void check_driver_call(int rc, uint32_t budget_us, const char *what) {
    check_error_origin(rc);
    check_bound((uint64_t)budget_us + fz.max_wire_us, what);
    if (fz.failed > 0u) {
        FUZZ_CHECK(rc != HAL_OK);
    }
}

static uint32_t or_default(uint32_t v, uint32_t fallback) {
    return v != 0u ? v : fallback;
}

static uint32_t call_budget(size_t i) {
    return or_default(fz.cfg[i].call_budget_us, VL53_DEFAULT_CALL_BUDGET_US);
}

/* An accepted result is a new measurement: its stream count differs from the one the
 * driver accepted last (captured before the call: a poll whose interrupt clear fails
 * still consumes the result it read, vl53.h). */
static void check_result(size_t i, int rc, const struct vl53_result *r) {
    if (trace) {
        const struct vl53_dev *d = &fz.array.dev[i];
        fprintf(stderr, "  sensor %zu: rc %d stream %u missed %u (driver: last %u%s, cand %u%s)\n",
                i, rc, r->stream_count, r->missed, d->last_stream, d->have_stream ? "" : "?",
                d->candidate_stream, d->have_candidate ? "" : "?");
    }
    if (rc != HAL_OK) {
        return;
    }
    FUZZ_CHECK(r->raw_status <= VL53_RANGE_STATUS_RAW_MASK);
    /* ST's status, or the driver's marks on a valid one (vl53.h): first after a start,
     * implausible distance; a hardware-fault status is never an OK result. */
    uint8_t expect = vl53_range_status_from_raw(r->raw_status);
    if ((r->flags & VL53_RESULT_FIRST) != 0u && expect == VL53_RANGE_VALID) {
        expect = VL53_RANGE_NO_WRAP_CHECK;
    }
    if ((r->flags & VL53_RESULT_IMPLAUSIBLE) != 0u &&
        (expect == VL53_RANGE_VALID || expect == VL53_RANGE_NO_WRAP_CHECK)) {
        expect = VL53_RANGE_IMPLAUSIBLE;
    }
    FUZZ_CHECK(r->range_status == expect);
    FUZZ_CHECK((r->flags & VL53_RESULT_HW_FAULT) == 0u);
    FUZZ_CHECK(r->range_status != VL53_RANGE_UNKNOWN);
    FUZZ_CHECK(r->time_us - call_start32 <= (uint32_t)(fz.now - call_start));
    if (fz.have_stream[i]) {
        FUZZ_CHECK(r->stream_count != fz.last_stream[i]);
    }
}

static void note_stream_before(size_t i) {
    const struct vl53_dev *d = &fz.array.dev[i];
    fz.have_stream[i] = d->have_stream;
    fz.last_stream[i] = d->last_stream;
}

/* The reports after a bring-up or a recovery: ranging and clean, or parked with a fault. */
static void check_report(size_t i) {
    const struct vl53_sensor_report *rep = vl53_array_report(&fz.array, i);
    FUZZ_CHECK(rep != NULL);
    if (rep->state == VL53_SENSOR_RANGING) {
        FUZZ_CHECK(rep->fault == VL53_ARRAY_OK && rep->err == HAL_OK);
        FUZZ_CHECK(vl53_current_address(&fz.array.dev[i]) == fz.cfg[i].address);
    } else {
        FUZZ_CHECK(rep->state == VL53_SENSOR_OFF);
        FUZZ_CHECK(rep->fault != VL53_ARRAY_OK && rep->err < 0 && is_hal_err(rep->err));
        /* parked in reset, unless the XSHUT write itself failed */
        FUZZ_CHECK(!vl53_is_ranging(&fz.array.dev[i]) || fz.xshut_failed);
    }
    FUZZ_CHECK(vl53_array_fault_name(rep->fault) != NULL);
}

/* --- operations ----------------------------------------------------------------------------- */

static size_t arg_index(void) {
    return next(FZ_ARG, NULL) % fz.count;
}

static void op_bring_up(void) {
    begin_call();
    const int rc = vl53_array_bring_up(&fz.array);
    check_error_origin(rc);
    const uint64_t steps = fz.count * VL53_ARRAY_STEPS_PER_SENSOR + 1u + fz.count;
    check_bound(vl53_array_bring_up_budget_us(&fz.array) + steps * fz.max_wire_us + FZ_RECOVER_US,
                "vl53_array_bring_up");
    bool all = true;
    bool rc_reported = rc == HAL_OK;
    for (size_t i = 0; i < fz.count; ++i) {
        check_report(i);
        const struct vl53_sensor_report *rep = vl53_array_report(&fz.array, i);
        all = all && rep->state == VL53_SENSOR_RANGING;
        rc_reported = rc_reported || rep->err == rc;
    }
    FUZZ_CHECK((rc == HAL_OK) == all);
    FUZZ_CHECK(rc_reported); /* the error returned is a sensor's reported one */
    FUZZ_CHECK(vl53_array_ranging_count(&fz.array) <= fz.count);
}

static void op_recover_sensor(void) {
    const size_t i = next(FZ_ARG, NULL) % (fz.count + 1u); /* count: out of range */
    begin_call();
    const int rc = vl53_array_recover_sensor(&fz.array, i);
    check_error_origin(rc);
    if (i >= fz.count) {
        FUZZ_CHECK(rc == HAL_ERR_INVALID && fz.now == call_start);
        FUZZ_CHECK(vl53_array_recover_budget_us(&fz.array, i) == 0u);
        return;
    }
    check_bound(vl53_array_recover_budget_us(&fz.array, i) +
                    (uint64_t)VL53_ARRAY_STEPS_PER_SENSOR * fz.max_wire_us,
                "vl53_array_recover_sensor");
    check_report(i);
    const struct vl53_sensor_report *rep = vl53_array_report(&fz.array, i);
    FUZZ_CHECK((rc == HAL_OK) == (rep->state == VL53_SENSOR_RANGING));
    if (rc != HAL_OK) {
        FUZZ_CHECK(rep->err == rc);
    }
}

static void op_recover_bus(void) {
    begin_call();
    const int rc = vl53_array_recover_bus(&fz.array);
    FUZZ_CHECK(rc == HAL_OK || rc == HAL_ERR_BUS_STUCK || rc == HAL_ERR_INVALID);
    FUZZ_CHECK((rc == HAL_ERR_INVALID) == !fz.recover_hook);
    check_bound(fz.recover_hook ? FZ_RECOVER_US : 0u, "vl53_array_recover_bus");
}

static void poll_one(size_t i) {
    struct vl53_result r;
    memset(&r, 0xA5, sizeof r);
    const bool was_ranging = vl53_is_ranging(&fz.array.dev[i]);
    note_stream_before(i);
    begin_call();
    const int rc = vl53_array_poll(&fz.array, i, &r);
    check_driver_call(rc, call_budget(i), "vl53_array_poll");
    if (!was_ranging) {
        FUZZ_CHECK(rc == HAL_ERR_STATE && fz.now == call_start);
    }
    if (rc == HAL_ERR_NOT_READY && fz.cfg[i].gpio1_pin != VL53_PIN_NONE) {
        FUZZ_CHECK(fz.now == call_start); /* GPIO1 wired: no bus traffic for "no data" */
    }
    check_result(i, rc, &r);
}

static void op_set_timing(void) {
    const size_t i = arg_index();
    const uint8_t which = next(FZ_ARG, NULL);
    const uint8_t value = next(FZ_ARG, NULL);
    struct vl53_dev *dev = vl53_array_sensor(&fz.array, i);
    const bool ranging = vl53_is_ranging(dev);
    const struct vl53_timing before = dev->timing;
    struct vl53_timing t = timings[value % TIMINGS];
    bool valid = true;
    begin_call();
    int rc;
    switch (which % 4u) {
    case 0:
        if ((which & 0x80u) != 0u) {              /* an invalid combination */
            t.inter_measurement_ms = t.budget_ms; /* below budget + 4 ms */
            valid = false;
        }
        rc = vl53_set_timing(dev, &t);
        break;
    case 1:
        t.mode = (enum vl53_distance_mode)(value % 4u);
        valid = vl53_timing_check(&(struct vl53_timing){t.mode, before.budget_ms,
                                                        before.inter_measurement_ms}) == HAL_OK;
        rc = vl53_set_distance_mode(dev, t.mode);
        break;
    case 2:
        t.budget_ms = (uint16_t)(value * 3u);
        valid = vl53_timing_check(&(struct vl53_timing){before.mode, t.budget_ms,
                                                        before.inter_measurement_ms}) == HAL_OK;
        rc = vl53_set_timing_budget(dev, t.budget_ms);
        break;
    default:
        t.inter_measurement_ms = (uint32_t)value * 41u;
        valid = vl53_timing_check(&(struct vl53_timing){before.mode, before.budget_ms,
                                                        t.inter_measurement_ms}) == HAL_OK;
        rc = vl53_set_inter_measurement(dev, t.inter_measurement_ms);
        break;
    }
    check_driver_call(rc, call_budget(i), "vl53_set_timing");
    if (!valid) {
        FUZZ_CHECK(rc == HAL_ERR_INVALID && fz.now == call_start); /* before any bus access */
    } else if (ranging) {
        FUZZ_CHECK(rc == HAL_ERR_STATE && fz.now == call_start);
    }
    if (rc != HAL_OK) {
        FUZZ_CHECK(memcmp(&dev->timing, &before, sizeof before) == 0);
    } else {
        FUZZ_CHECK(vl53_timing_check(&dev->timing) == HAL_OK);
    }
}

static void op_wait_boot(size_t i) {
    struct vl53_dev *dev = vl53_array_sensor(&fz.array, i);
    begin_call();
    /* When the part powered up, as the driver's 32-bit clock knows it. */
    const uint64_t since_power_up = (uint32_t)(call_start32 - dev->power_up_us);
    const int rc = vl53_wait_boot(dev);
    check_error_origin(rc);
    const uint64_t boot_end = VL53_BOOT_TIME_MAX_US + VL53_BOOT_SLACK_US;
    const uint64_t by_boot = boot_end > since_power_up ? boot_end - since_power_up : 0u;
    const uint64_t bound = by_boot > VL53_BOOT_POLL_US ? by_boot : VL53_BOOT_POLL_US;
    check_bound(bound + fz.max_wire_us, "vl53_wait_boot");
}

static void op_driver(enum fz_op op) {
    const size_t i = arg_index();
    struct vl53_dev *dev = vl53_array_sensor(&fz.array, i);
    FUZZ_CHECK(dev != NULL);
    const uint32_t budget = call_budget(i);
    int rc;
    switch (op) {
    case FZ_OP_DATA_READY: {
        bool ready = false;
        begin_call();
        rc = vl53_data_ready(dev, &ready);
        check_driver_call(rc, budget, "vl53_data_ready");
        break;
    }
    case FZ_OP_START:
        begin_call();
        rc = vl53_start_ranging(dev);
        check_driver_call(rc, budget, "vl53_start_ranging");
        FUZZ_CHECK(rc != HAL_OK || vl53_is_ranging(dev));
        break;
    case FZ_OP_STOP:
        begin_call();
        rc = vl53_stop_ranging(dev);
        check_driver_call(rc, budget, "vl53_stop_ranging");
        FUZZ_CHECK(rc != HAL_OK || !vl53_is_ranging(dev));
        break;
    case FZ_OP_READ_RESULT: {
        struct vl53_result r;
        memset(&r, 0xA5, sizeof r);
        note_stream_before(i);
        begin_call();
        rc = vl53_read_result(dev, &r);
        check_driver_call(rc, budget, "vl53_read_result");
        check_result(i, rc, &r);
        break;
    }
    case FZ_OP_CONFIGURE:
        begin_call();
        rc = vl53_configure(dev);
        /* begin (call budget) then finish (configure budget), one transfer each over; a
         * data-ready poll of the VHV wait lost to a bus error is retried, not failed. */
        check_error_origin(rc);
        check_bound(
            (uint64_t)budget +
                or_default(fz.cfg[i].configure_budget_us, VL53_DEFAULT_CONFIGURE_BUDGET_US) +
                2u * fz.max_wire_us,
            "vl53_configure");
        FUZZ_CHECK(rc != HAL_OK || !vl53_is_ranging(dev));
        break;
    case FZ_OP_IDENTIFY: {
        uint16_t id = 0;
        begin_call();
        rc = vl53_identify(dev, &id);
        check_driver_call(rc, budget, "vl53_identify");
        FUZZ_CHECK(rc != HAL_OK || id == VL53_MODEL_ID_VL53L1X);
        break;
    }
    case FZ_OP_SET_ADDRESS: {
        const uint8_t addr = (uint8_t)(next(FZ_ARG, NULL) & 0x7Fu);
        const uint8_t before = vl53_current_address(dev);
        begin_call();
        rc = vl53_set_address(dev, addr);
        check_driver_call(rc, budget, "vl53_set_address");
        if (addr < 0x08u || addr > 0x77u) {
            FUZZ_CHECK(rc == HAL_ERR_INVALID && fz.now == call_start);
        }
        /* moved once the write went through, kept otherwise */
        FUZZ_CHECK(vl53_current_address(dev) == before || vl53_current_address(dev) == addr);
        FUZZ_CHECK(rc != HAL_OK || vl53_current_address(dev) == addr);
        break;
    }
    case FZ_OP_WAIT_BOOT:
        op_wait_boot(i);
        break;
    case FZ_OP_CLEAR_IRQ:
        begin_call();
        rc = vl53_clear_interrupt(dev);
        check_driver_call(rc, budget, "vl53_clear_interrupt");
        break;
    case FZ_OP_GPIO1_READY: {
        bool ready = false;
        begin_call();
        rc = vl53_gpio1_ready(dev, &ready);
        check_driver_call(rc, 0u, "vl53_gpio1_ready"); /* no bus, no time */
        FUZZ_CHECK(fz.cfg[i].gpio1_pin != VL53_PIN_NONE || rc == HAL_ERR_INVALID);
        break;
    }
    default: { /* FZ_OP_POWER */
        const bool up = (next(FZ_ARG, NULL) & 1u) != 0u;
        begin_call();
        rc = up ? vl53_power_up(dev) : vl53_shutdown(dev);
        check_driver_call(rc, 0u, up ? "vl53_power_up" : "vl53_shutdown");
        if (rc == HAL_OK) {
            FUZZ_CHECK(vl53_current_address(dev) == VL53_DEFAULT_ADDRESS);
            FUZZ_CHECK(!vl53_is_ranging(dev));
        }
        break;
    }
    }
}

static void op_poll_loop(void) {
    const unsigned ticks = 1u + next(FZ_ARG, NULL);
    const uint32_t tick_us = 1000u * (1u + next(FZ_ARG, NULL) % 50u);
    for (unsigned t = 0; t < ticks; ++t) {
        for (size_t i = 0; i < fz.count; ++i) {
            if (vl53_is_ranging(&fz.array.dev[i])) {
                poll_one(i);
            }
        }
        fz.now += tick_us;
    }
}

/* --- a run ---------------------------------------------------------------------------------- */

/* Reads the configuration; true when it was deliberately broken (FZ_CFG_BAD_CONFIG). */
static bool configure(void) {
    fz.count = 1u + next(FZ_CONFIG, NULL) % SENSORS_MAX;
    uint32_t origin = 0;
    for (unsigned b = 0; b < 4u; ++b) {
        origin |= (uint32_t)next(FZ_CONFIG, NULL) << (8u * b);
    }
    fz.origin = origin;
    const uint8_t flags = next(FZ_CONFIG, NULL);
    const struct vl53_timing timing = timings[next(FZ_CONFIG, NULL) % TIMINGS];
    const uint32_t call = PICK(call_budgets, next(FZ_CONFIG, NULL));
    const uint32_t configure_budget = PICK(configure_budgets, next(FZ_CONFIG, NULL));
    const uint32_t i2c_timeout = PICK(i2c_timeouts, next(FZ_CONFIG, NULL));
    const uint32_t poll = PICK(poll_intervals, next(FZ_CONFIG, NULL));
    fz.recover_hook = (flags & FZ_CFG_NO_RECOVER) == 0u;
    memset(vendor_block, 0, sizeof vendor_block);
    vendor_block[VL53_REG_GPIO_HV_MUX_CTRL - VL53_REG_DEFAULT_CONFIG_FIRST] =
        (flags & FZ_CFG_ACTIVE_LOW) != 0u ? 0x11u : 0x01u;
    for (size_t i = 0; i < fz.count; ++i) {
        struct vl53_config *c = &fz.cfg[i];
        memset(c, 0, sizeof *c);
        c->i2c.ops = fz.recover_hook ? &i2c_ops : &i2c_ops_no_recover;
        c->gpio.ops = &gpio_ops;
        c->time.ops = &time_ops;
        c->address = (uint8_t)(FZ_FIRST_ADDRESS + i);
        c->xshut_pin = FZ_XSHUT_PIN(i);
        c->gpio1_pin = (flags & FZ_CFG_GPIO1) != 0u ? FZ_GPIO1_PIN(i) : VL53_PIN_NONE;
        c->polarity =
            (flags & FZ_CFG_ACTIVE_LOW) != 0u ? VL53_INT_ACTIVE_LOW : VL53_INT_ACTIVE_HIGH;
        c->timing = timing;
        c->call_budget_us = call;
        c->configure_budget_us = configure_budget;
        c->i2c_timeout_us = i2c_timeout;
        c->poll_interval_us = poll;
        c->verify_distance = (flags & FZ_CFG_VERIFY) != 0u;
        c->vendor_default_config = (flags & FZ_CFG_VENDOR) != 0u ? vendor_block : NULL;
    }
    fz.acfg.sensors = fz.cfg;
    fz.acfg.count = fz.count;
    if ((flags & FZ_CFG_BAD_CONFIG) == 0u) {
        return false;
    }
    /* One way to be wrong, chosen by the clock origin's low bits. */
    struct vl53_config *last = &fz.cfg[fz.count - 1u];
    switch (origin % 6u) {
    case 0:
        last->address = VL53_DEFAULT_ADDRESS; /* the array needs it free */
        break;
    case 1:
        last->address = 0x78u; /* reserved */
        break;
    case 2:
        last->timing.inter_measurement_ms = last->timing.budget_ms; /* no 4 ms margin */
        break;
    case 3:
        last->xshut_pin = VL53_PIN_NONE; /* the array needs every XSHUT */
        break;
    case 4:
        if (fz.count > 1u) { /* a duplicate address */
            last->address = fz.cfg[0].address;
        } else {
            last->polarity = (enum vl53_polarity)2;
        }
        break;
    default:
        last->time.ops = NULL;
        break;
    }
    return true;
}

void fz_vl53_run(const struct fz_source *src) {
    trace = getenv("FZ_TRACE") != NULL; /* FZ_TRACE=1 ./fuzz_vl53 crash-...: what happened */
    memset(&fz, 0, sizeof fz);
    fz.src = src;
    const bool bad_config = configure();
    memset(&fz.array, 0x5A, sizeof fz.array); /* attach must not rely on a zeroed struct */
    const int rc = vl53_array_attach(&fz.array, &fz.acfg);
    if (bad_config) {
        FUZZ_CHECK(rc == HAL_ERR_INVALID && fz.now == 0u);
        return;
    }
    FUZZ_CHECK(rc == HAL_OK);
    for (unsigned ops = 0; ops < 512u && !src->done(src->ctx); ++ops) {
        const enum fz_op op = (enum fz_op)(next(FZ_OP, NULL) % FZ_OP_COUNT);
        if (trace) {
            fprintf(stderr, "t=%llu op %d\n", (unsigned long long)fz.now, (int)op);
        }
        switch (op) {
        case FZ_OP_BRING_UP:
            op_bring_up();
            break;
        case FZ_OP_RECOVER_SENSOR:
            op_recover_sensor();
            break;
        case FZ_OP_RECOVER_BUS:
            op_recover_bus();
            break;
        case FZ_OP_POLL:
            poll_one(arg_index());
            break;
        case FZ_OP_SLEEP: {
            const uint8_t a = next(FZ_ARG, NULL);
            fz.now += (uint64_t)(a & 63u) << (5u * (a >> 6));
            break;
        }
        case FZ_OP_SET_TIMING:
            op_set_timing();
            break;
        case FZ_OP_LONG_SLEEP: {
            uint32_t us = 0;
            for (unsigned b = 0; b < 4u; ++b) {
                us |= (uint32_t)next(FZ_ARG, NULL) << (8u * b);
            }
            fz.now += us;
            break;
        }
        case FZ_OP_POLL_LOOP:
            op_poll_loop();
            break;
        default:
            op_driver(op);
            break;
        }
    }
}
