/*
 * VL53L1X-class Time-of-Flight sensor driver over hal/ (I²C, GPIO, time).
 *
 * One `struct vl53_dev` (mutable state) per sensor, bound to one const
 * `struct vl53_config` (bus, address, pins, timing); any number of sensors, no
 * globals. Every call returns HAL_OK or a negative hal_err code passed up
 * unchanged from the bus, and every call is bounded in time:
 *   - vl53_wait_boot():  the later of power-up + VL53_BOOT_TIME_MAX_US + VL53_BOOT_SLACK_US
 *                        and call start + VL53_BOOT_POLL_US, plus one transfer;
 *   - vl53_configure():  call_budget_us + configure_budget_us plus two transfers (it is
 *                        vl53_configure_begin() then vl53_configure_finish());
 *   - vl53_configure_finish(): configure_budget_us plus one transfer;
 *   - vl53_read_part_id(): four call_budget_us plus one transfer (NVM on, each of two
 *                        words, the restore: one budget each);
 *   - every other call:  call_budget_us plus one transfer,
 * where "one transfer" is the wire time of the call's longest single transfer (the
 * hal_i2c contract: a transfer never takes longer than its timeout plus its wire time,
 * and the driver never passes a timeout beyond what is left of the call's budget).
 * Register facts and their sources: vl53_regs.h. Details and limits:
 * docs/explanation/driver-and-bus.md.
 */
#ifndef VL53_H
#define VL53_H

#include <stdbool.h>
#include <stdint.h>

#include "hal/hal_gpio.h"
#include "hal/hal_i2c.h"
#include "hal/hal_time.h"
#include "vl53/vl53_regs.h"

/* A pin number meaning "not wired". */
#define VL53_PIN_NONE 0xFFFFu

/* Boot takes at most 1.2 ms after XSHUT rises ([DS] power-up sequence, tBOOT, [I4]). */
#define VL53_BOOT_TIME_MAX_US 1200u
/* Our margin on top of it: tBOOT counts from XSHUT reaching its high level, and on a board
 * XSHUT rises through a pull-up into the pin's capacitance; 2 ms cover an RC of up to 0.5 ms
 * (e.g. 47 kΩ and 10 nF) to 98 %, clock tolerance and the last poll's transfer. */
#define VL53_BOOT_SLACK_US 2000u
/* Boot-state poll interval while waiting. */
#define VL53_BOOT_POLL_US 100u
/* Inter-measurement period must exceed the timing budget by at least this much ([I4], [ULD]). */
#define VL53_IMP_MARGIN_MS 4u
/* Largest inter-measurement period accepted (keeps the 32-bit register from overflowing). */
#define VL53_IMP_MAX_MS 10000u

/* Defaults used when a config field is 0. */
#define VL53_DEFAULT_I2C_TIMEOUT_US 2000u
#define VL53_DEFAULT_CALL_BUDGET_US 10000u
/* vl53_configure_finish(): the VHV range at the block's own ~100 ms timing, twice over. */
#define VL53_DEFAULT_CONFIGURE_BUDGET_US 200000u
#define VL53_DEFAULT_POLL_INTERVAL_US    1000u
/* Extra time past the expected measurement before vl53_poll() reports data overdue. */
#define VL53_DATA_SLACK_US 2000u

/* ULD range status codes ([ULD] UM2510 "range status"); 255 = raw code ST does not map. */
enum vl53_range_status {
    VL53_RANGE_VALID = 0,
    VL53_RANGE_SIGMA_FAIL = 1,
    VL53_RANGE_SIGNAL_FAIL = 2,
    VL53_RANGE_MIN_RANGE = 3, /* target below minimum detection range (clipped) */
    VL53_RANGE_OUT_OF_BOUNDS = 4,
    VL53_RANGE_HARDWARE_FAIL = 5,
    VL53_RANGE_NO_WRAP_CHECK = 6, /* valid, but the first after a start: not wrap-checked */
    VL53_RANGE_WRAP_AROUND = 7,
    /* 9..13 are further ULD codes ST documents only as "not valid"; passed as numbers. */
    VL53_RANGE_IMPLAUSIBLE = 254, /* ours: a distance the part cannot give as valid */
    VL53_RANGE_UNKNOWN = 255,
};

enum vl53_distance_mode {
    VL53_DISTANCE_SHORT = 1, /* up to ~1.3 m, better in ambient light */
    VL53_DISTANCE_LONG = 2,  /* up to ~4 m */
};

/* Largest distance each mode reports ([DS] maximum ranging distance: short 136 cm; long
 * "up to 4 m"); a reading beyond it is implausible. */
#define VL53_RANGE_MAX_SHORT_MM 1360u
#define VL53_RANGE_MAX_LONG_MM  4000u

/* The largest distance `mode` reports as valid (short's for anything but long). */
uint16_t vl53_range_max_mm(enum vl53_distance_mode mode);

/* The shortest timing budget `mode` has (short 15 ms, long 20 ms; [ULD] tables), or 0 for
 * an unknown mode. */
uint16_t vl53_shortest_budget_ms(enum vl53_distance_mode mode);

/* "short" or "long" (as traces and command lines spell them); "short" for anything but long. */
const char *vl53_distance_mode_name(enum vl53_distance_mode mode);

/* The mode spelled `name` ("short", "long"): true and *mode set, or false for any other. */
bool vl53_distance_mode_from_name(const char *name, enum vl53_distance_mode *mode);
/* Distances no valid reading has: 8190/8191 are the no-target codes, 65535 what a read of
 * an undriven bus (all ones) gives, 0 a target at the window. */
#define VL53_NO_TARGET_MM     8190u
#define VL53_NO_TARGET_ALT_MM 8191u
#define VL53_FAILED_READ_MM   65535u

/* struct vl53_result.flags */
#define VL53_RESULT_FIRST       0x01u /* first result after a (re)start: not wrap-checked */
#define VL53_RESULT_IMPLAUSIBLE 0x02u /* distance impossible as a valid reading in this mode */
#define VL53_RESULT_HW_FAULT    0x04u /* raw 1, 2, 3 or 17: the sensor's own hardware fault */

enum vl53_polarity {
    VL53_INT_ACTIVE_HIGH = 0, /* GPIO1 / TIO status bit 0 high when data is ready */
    VL53_INT_ACTIVE_LOW = 1,
};

/* Ranging timing: one of the ULD budgets, and a period at least budget + 4 ms. */
struct vl53_timing {
    enum vl53_distance_mode mode;
    uint16_t budget_ms;            /* 15 (short mode only), 20, 33, 50, 100, 200, 500 */
    uint32_t inter_measurement_ms; /* budget_ms + VL53_IMP_MARGIN_MS .. VL53_IMP_MAX_MS */
};

/*
 * The state the driver writes to the part's own offset registers at every bring-up
 * (vl53_configure_begin), whatever the part's NVM loaded there: the same readings on every
 * boot. All zero (the product's choice, docs/explanation/driver-and-bus.md "The parts' offset
 * registers"): the part reports its range uncorrected and the head calibration (HEAD.cal) owns the
 * offset.
 */
struct vl53_offsets {
    int16_t part_to_part_qmm; /* 0x001E, quarter mm (11.2): -4096..4095 = -1024..+1023.75 mm */
    int16_t inner_mm;         /* 0x0020, mm (MM1/MM2 steps, off in ST's block) */
    int16_t outer_mm;         /* 0x0022, mm */
};

/* Per-sensor constant configuration. Fields documented "0: default" take the VL53_DEFAULT_*. */
struct vl53_config {
    struct hal_i2c i2c;
    struct hal_gpio gpio; /* XSHUT output and GPIO1 input; ops may be NULL if neither is wired */
    struct hal_time time;
    uint8_t address;    /* 7-bit address this sensor is moved to (0x08..0x77, not 0x29) */
    uint16_t xshut_pin; /* VL53_PIN_NONE: XSHUT not under our control */
    uint16_t gpio1_pin; /* VL53_PIN_NONE: data ready read from GPIO__TIO_HV_STATUS */
    enum vl53_polarity polarity;
    struct vl53_timing timing;
    uint32_t i2c_timeout_us;      /* per transfer (clock stretching), 0: default */
    uint32_t call_budget_us;      /* per call at 400 kHz, 0: default (vl53_call_budget_us()) */
    uint32_t bus_hz;              /* the bus clock (100000 or 400000), 0: 400 kHz */
    uint32_t configure_budget_us; /* for vl53_configure(), 0: default */
    uint32_t poll_interval_us;    /* least gap between data-ready register reads, 0: default */
    /* Re-read the distance after each result and compare: catches bit errors in the
     * distance field (the part has no CRC) for one 2-byte read per sample. */
    bool verify_distance;
    /* I²C lines and GPIO1 pulled up to AVDD (2V8..3V3, as on the NUCLEO boards), not 1V8:
     * bit 0 of 0x2E and 0x2F in the default configuration ([ULD] table comments). */
    bool pads_at_avdd;
    /* NULL: ST's default configuration (vl53_default_config.h), always written at init.
     * Otherwise 91 bytes written instead (an integrator's override, e.g. a newer ST table). */
    const uint8_t *vendor_default_config;
    /* Written to 0x1E/0x20/0x22 at every bring-up and read back; zero-initialised: all 0. */
    struct vl53_offsets offsets;
};

/* The budget of one ordinary call of a sensor configured as `cfg`: call_budget_us (or its
 * default), which bounds a call's transfers at 400 kHz, scaled by 400 kHz / bus_hz, rounded
 * up, on a slower bus: the longest call (the configuration's 91-byte write and read-back) has
 * four times the wire time at 100 kHz. */
uint32_t vl53_call_budget_us(const struct vl53_config *cfg);

/* One measurement as read from the result block. */
struct vl53_result {
    uint16_t distance_mm;
    uint8_t range_status;  /* enum vl53_range_status (ULD code) */
    uint8_t raw_status;    /* low 5 bits of RESULT__RANGE_STATUS */
    uint8_t stream_count;  /* RESULT__STREAM_COUNT */
    uint8_t missed;        /* measurements completed but never read since the previous result */
    uint8_t flags;         /* VL53_RESULT_* */
    uint8_t spad_count;    /* effective SPADs (integer part) */
    uint32_t signal_kcps;  /* peak signal rate, crosstalk corrected */
    uint32_t ambient_kcps; /* ambient rate */
    uint32_t time_us;      /* hal_time when the block was read */
};

/* Mutable per-sensor state. Treat as opaque; read it only through the functions below. */
struct vl53_dev {
    const struct vl53_config *cfg;
    struct vl53_timing timing; /* active timing (config's until changed) */
    uint8_t address;           /* where the sensor answers now */
    bool ranging;
    bool have_stream; /* last_stream holds the stream count of an accepted result */
    uint8_t last_stream;
    bool have_candidate; /* a refused stream count the next one may confirm */
    uint8_t candidate_stream;
    uint32_t candidate_us;
    uint32_t power_up_us; /* when XSHUT rose (or attach time) */
    uint32_t ranging_start_us;
    uint32_t last_result_us;   /* read time of the last accepted result (or ranging start) */
    uint32_t data_deadline_us; /* poll reports HAL_ERR_TIMEOUT once this passes with no data */
    uint32_t next_register_poll_us;
    uint8_t boot_state; /* FIRMWARE__SYSTEM_STATUS when vl53_wait_boot() saw it booted */
    bool vhv_running;   /* a VHV range runs (vl53_configure_begin, vl53_temperature_update_begin) */
    uint32_t vhv_start_us;
    uint16_t offset_mismatch_reg; /* see vl53_offset_mismatch_register() */
    uint64_t part_id;             /* see vl53_part_id() */
};

/*
 * Bind `dev` to `cfg` (kept by pointer) and validate the configuration; no bus access.
 * The sensor is assumed to answer at VL53_DEFAULT_ADDRESS, not ranging. HAL_ERR_INVALID
 * names nothing itself: see vl53_config_check() for which field is wrong.
 */
int vl53_attach(struct vl53_dev *dev, const struct vl53_config *cfg);

/* The first invalid field of `cfg` as a static string ("address", "timing", ...), or NULL. */
const char *vl53_config_check(const struct vl53_config *cfg);

/* HAL_OK if `timing` is a combination the part supports, else HAL_ERR_INVALID. */
int vl53_timing_check(const struct vl53_timing *timing);

/* Drive XSHUT low: the part powers down and forgets its address and configuration. */
int vl53_shutdown(struct vl53_dev *dev);

/* Drive XSHUT high and note the time: the part boots at VL53_DEFAULT_ADDRESS. */
int vl53_power_up(struct vl53_dev *dev);

/*
 * Wait until FIRMWARE__SYSTEM_STATUS is non-zero (booted; 0x02/0x03 from a part that kept
 * power across an MCU reset count too, see vl53_warm_boot()) at the current address,
 * returning by the later of power-up + VL53_BOOT_TIME_MAX_US + VL53_BOOT_SLACK_US and call
 * start + VL53_BOOT_POLL_US, plus one transfer. HAL_OK;
 * HAL_ERR_TIMEOUT if the part answered but never booted; otherwise the last bus error
 * (HAL_ERR_ADDR_NACK: nothing answered, e.g. a missing sensor).
 */
int vl53_wait_boot(struct vl53_dev *dev);

/* Read the model ID into *model_id (if not NULL); HAL_ERR_ID_MISMATCH unless 0xEACC. */
int vl53_identify(struct vl53_dev *dev, uint16_t *model_id);

/*
 * Move the part to 7-bit `new_address` and confirm its model ID there. On a failed write
 * the driver keeps the old address; on a failed confirmation it assumes the new one.
 */
int vl53_set_address(struct vl53_dev *dev, uint8_t new_address);

/*
 * Read the part's identity from its NVM (vl53_nvm.c, ST's NVM-read sequence, [NVM] in
 * vl53_regs.h): the 8 bytes at NVM 0x1F8..0x1FF (lot, wafer, die X and Y), the first as the
 * most significant, into *part_id (if not NULL) and kept for vl53_part_id(). Call it stopped
 * (HAL_ERR_STATE while ranging or during a configuration), e.g. right after boot: the part's
 * firmware is off during the read and switched on again afterwards, even after a failure
 * (its own budget), and the first error is returned unchanged; the identity is then 0.
 * Within four call budgets (above).
 */
int vl53_read_part_id(struct vl53_dev *dev, uint64_t *part_id);

/* The identity the last vl53_read_part_id() read since power-up, or 0 if none did. */
uint64_t vl53_part_id(const struct vl53_dev *dev);

/* The offset register (0x001E, 0x0020 or 0x0022) whose read-back differed from what the
 * last vl53_configure_begin() wrote, or 0 if none did. */
uint16_t vl53_offset_mismatch_register(const struct vl53_dev *dev);

/* True if the last successful vl53_wait_boot() read a boot state other than 0x01: the part
 * had been running before (it kept power across an MCU reset). */
bool vl53_warm_boot(const struct vl53_dev *dev);

/*
 * First half of ST's bring-up (docs/explanation/driver-and-bus.md): stop, write the 91-byte default
 * configuration (pads per cfg->pads_at_avdd), write cfg->offsets to 0x1E..0x23 and read them
 * back, and start the VHV range, which runs at the block's own timing (~100 ms). Returns at
 * once (call_budget_us); other sensors can be brought up meanwhile. Finish with
 * vl53_configure_finish(). An offset register that reads back otherwise, twice alike with
 * the model ID read right between, is HAL_ERR_DEVICE (the part does not take the value;
 * vl53_offset_mismatch_register() names it); otherwise a mismatch is HAL_ERR_CORRUPT.
 */
int vl53_configure_begin(struct vl53_dev *dev);

/*
 * Second half: wait for the VHV range's data ready, clear, stop, VHV loop bound 0x09 and
 * init 0x00 ([ULD] SensorInit), then interrupt polarity, distance mode, timing budget and
 * inter-measurement period as the ULD writes them, each region read back and compared
 * (HAL_ERR_CORRUPT on a mismatch). Bounded by configure_budget_us; HAL_ERR_STATE without a
 * begin. Leaves ranging stopped.
 */
int vl53_configure_finish(struct vl53_dev *dev);

/*
 * Has the VHV range started by vl53_configure_begin() finished? One look, no waiting (GPIO1
 * when wired, else one register read): HAL_OK when its data is ready (vl53_configure_finish()
 * then returns without waiting), HAL_ERR_NOT_READY while it runs, HAL_ERR_TIMEOUT once
 * configure_budget_us since the begin has passed without it, HAL_ERR_STATE without a begin,
 * or the bus error of the read. Lets a caller finish the bring-up without blocking.
 */
int vl53_configure_pending(struct vl53_dev *dev);

/*
 * ST's temperature update, the VHV recalibration ([ULD] StartTemperatureUpdate: ST asks for it
 * whenever the temperature may have moved by more than 8 °C), in two halves so other sensors
 * keep ranging meanwhile. Begin: with ranging stopped (HAL_ERR_STATE otherwise, or while a VHV
 * range runs), 0x0008 <- 0x81, 0x000B <- 0x92, start ranging (0x0087 <- 0x40). Pending: one
 * look at data ready (at cfg->polarity), HAL_OK once the range is done, HAL_ERR_NOT_READY
 * while it runs, HAL_ERR_TIMEOUT after twice (budget + inter-measurement period), at least
 * configure_budget_us. Finish: wait for data ready (bounded the same), clear the interrupt
 * (0x0086 <- 0x01), stop (0x0087 <- 0x00), 0x0008 <- 0x09, 0x000B <- 0x00; leaves ranging
 * stopped (start it again with vl53_start_ranging). The range's result is the VHV search's,
 * never a distance: it is not read.
 */
int vl53_temperature_update_begin(struct vl53_dev *dev);
int vl53_temperature_update_pending(struct vl53_dev *dev);
int vl53_temperature_update_finish(struct vl53_dev *dev);

/* vl53_configure_begin() then vl53_configure_finish(). */
int vl53_configure(struct vl53_dev *dev);

/* Change the timing (ranging must be stopped: HAL_ERR_STATE). Invalid combos: HAL_ERR_INVALID
 * before any bus access. */
int vl53_set_timing(struct vl53_dev *dev, const struct vl53_timing *timing);
/* The timing the next configuration writes (vl53_configure_finish(), a re-initialisation),
 * without a bus transfer: for a part that is off, failed or between the halves of its
 * configuration. HAL_ERR_INVALID for a timing the part cannot run, HAL_ERR_STATE while
 * ranging. */
int vl53_set_timing_next(struct vl53_dev *dev, const struct vl53_timing *timing);
/* Same, changing one parameter of the active timing. */
int vl53_set_distance_mode(struct vl53_dev *dev, enum vl53_distance_mode mode);
int vl53_set_timing_budget(struct vl53_dev *dev, uint16_t budget_ms);
int vl53_set_inter_measurement(struct vl53_dev *dev, uint32_t period_ms);

/* Clear any pending interrupt and start timed ranging. */
int vl53_start_ranging(struct vl53_dev *dev);
/* Stop ranging. */
int vl53_stop_ranging(struct vl53_dev *dev);

/* Data ready from GPIO__TIO_HV_STATUS (one 1-byte register read), polarity-aware. */
int vl53_data_ready(struct vl53_dev *dev, bool *ready);
/* Data ready from the GPIO1 pin (no bus traffic), polarity-aware; HAL_ERR_INVALID if unwired. */
int vl53_gpio1_ready(struct vl53_dev *dev, bool *ready);

/*
 * Read and check the 17-byte result block. HAL_OK with *result filled; HAL_ERR_DEVICE
 * (result filled, VL53_RESULT_HW_FAULT, status VL53_RANGE_HARDWARE_FAIL) when the part
 * reports its own hardware fault (raw 1, 2, 3, 17, confirmed by a 1-byte re-read of the
 * status): re-initialise that sensor, the bus is fine; HAL_ERR_CORRUPT (result still filled) when
 * the raw status is one ST does not map, the stream count did not advance (stale block) or advanced
 * inconsistently with the time elapsed, or the distance re-read (verify_distance) differs. The
 * first result after a start is accepted with any stream count (the part's count does not restart)
 * and marked VL53_RESULT_FIRST, status VL53_RANGE_NO_WRAP_CHECK if it came as valid. A distance the
 * mode cannot give as valid (0, 8190, 8191, 65535, beyond the mode's range) is marked
 * VL53_RESULT_IMPLAUSIBLE whatever its status, and a valid status becomes
 * VL53_RANGE_IMPLAUSIBLE.
 * Does not clear the interrupt.
 */
int vl53_read_result(struct vl53_dev *dev, struct vl53_result *result);

/* Write SYSTEM__INTERRUPT_CLEAR: arms the next data-ready. */
int vl53_clear_interrupt(struct vl53_dev *dev);

/*
 * Non-blocking acquisition step. HAL_ERR_NOT_READY (quickly, no bus traffic when GPIO1 is
 * wired or the next measurement is not yet due) if there is no new data; HAL_ERR_TIMEOUT if
 * data is overdue (no result for 1.5 periods + VL53_DATA_SLACK_US); else reads the result
 * (vl53_read_result), clears the interrupt and returns the first error of the two (the
 * result is filled whenever the read succeeded). HAL_ERR_STATE if not ranging.
 */
int vl53_poll(struct vl53_dev *dev, struct vl53_result *result);

/* True while ranging with no new result for 1.5 periods + VL53_DATA_SLACK_US: what makes
 * vl53_poll() return HAL_ERR_TIMEOUT without a bus timeout. No bus access. */
bool vl53_data_overdue(const struct vl53_dev *dev);

/* ULD range status for a raw RESULT__RANGE_STATUS value (masked to 5 bits). */
uint8_t vl53_range_status_from_raw(uint8_t raw);

/* Measurement period in µs of `timing`: max(budget, inter-measurement period). */
uint32_t vl53_period_us(const struct vl53_timing *timing);

/* The address the sensor answers at now, and whether it is ranging. */
uint8_t vl53_current_address(const struct vl53_dev *dev);
bool vl53_is_ranging(const struct vl53_dev *dev);

#endif /* VL53_H */
