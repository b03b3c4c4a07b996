/*
 * Device model of a VL53L1X-class ToF sensor behind the simulated I²C bus: a
 * register file with the side effects of the real part as ST describes it (boot delay
 * after XSHUT rises, address change, start/stop, data ready one timing budget after
 * start and then every period in simulated time, interrupt clear, the 17-byte result
 * block with range status and stream count, GPIO1 output with polarity), fed by a
 * struct sim_range_source. It ranges only once configured as ST's bring-up does it:
 * the default-configuration block 0x2D..0x87, the VHV step, a valid mode/budget
 * encoding (see sim_vl53_refusal). Its offset registers 0x1E/0x20/0x22 come from a per-part
 * NVM at power-up and shift the reported range as ST says; its NVM identity is read only through
 * ST's NVM-read sequence (firmware off, power force, NVM power-up, ...: sim_vl53_nvm.c), any
 * other access to those registers is NACKed. Integer only, no heap; built for
 * Cortex-M as well. Its register facts are its own (src/sim_vl53_regs.h, with sources), not the
 * driver's; which behaviours ST documents and which are the model's assumptions:
 * docs/explanation/driver-and-bus.md.
 */
#ifndef SIM_VL53_H
#define SIM_VL53_H

#include <stdbool.h>
#include <stdint.h>

#include "sim/range_source.h"
#include "sim/sim_clock.h"
#include "sim/sim_fault.h"
#include "sim/sim_gpio.h"
#include "sim/sim_i2c.h"

/* Registers 0x0000..0x01FF are modelled; other indices are protocol errors. */
#define SIM_VL53_REG_SPACE 0x0200u
/* At most this many measurements are computed one by one in a single catch-up; older
 * ones (after a long unobserved stretch of simulated time) are skipped in bulk. */
#define SIM_VL53_MAX_CATCH_UP 4096u

enum sim_vl53_index_mode {
    SIM_VL53_INDEX_PER_MEASUREMENT, /* 0, 1, 2, ... one per completed measurement (contract) */
    SIM_VL53_INDEX_BY_TIME,         /* completion time / index_period_us: stays in step with a
                                       trace across re-inits and restarts */
};

struct sim_vl53_config {
    unsigned sensor;             /* passed to the range source (0..3 = A..D) */
    bool xshut_wired;            /* false: XSHUT tied high, the part ignores the pin */
    bool powered_at_start;       /* XSHUT pulled high before the MCU drives it (boots at t=0) */
    uint32_t boot_us;            /* power-up -> booted (0: 1000; the datasheet max is 1200) */
    uint32_t boot_silent_us;     /* no ACK during this first part of boot (0: 300) */
    uint16_t osc_calibrate;      /* RESULT__OSC_CALIBRATE_VAL (0: 500, an arbitrary value) */
    uint16_t model_id;           /* IDENTIFICATION__MODEL_ID (0: 0xEACC) */
    bool ignores_address_change; /* defect: writes to 0x0001 are ACKed but change nothing */
    uint16_t ambient_raw;        /* AMBIENT_COUNT_RATE_MCPS_SD0, 9.7 format (0: 64) */
    enum sim_vl53_index_mode index_mode;
    uint32_t index_period_us; /* for SIM_VL53_INDEX_BY_TIME */
    /* What the part's NVM loads into its offset registers at every power-up (0 each: the
     * source's distances come out unchanged until something writes them). The range the
     * part reports is the source's distance plus 0x1E / 4 mm, rounded (src/sim_vl53_regs.h
     * [OFS]); 0x20 / 0x22 only serve the MM1/MM2 steps the model does not run. */
    int16_t nvm_part_to_part_qmm; /* 0x001E, quarter mm, -4096..4095 (13 bits kept) */
    int16_t nvm_inner_offset_mm;  /* 0x0020 */
    int16_t nvm_outer_offset_mm;  /* 0x0022 */
    bool ignores_offset_writes;   /* defect: writes to 0x1E..0x23 are ACKed but change nothing */
    /* The identity in the part's NVM bytes 0x1F8..0x1FF (lot, wafer, die X/Y; the first byte
     * most significant), served through the NVM-read registers (sim_vl53_nvm.c); 0:
     * SIM_VL53_DEFAULT_PART_ID(sensor), distinct per part. */
    uint64_t part_id;
    bool nvm_unreadable; /* defect: every access to an NVM-read register is NACKed */
};

/* The default identity of part `sensor` (0..3 = A..D): one made-up lot and wafer, die X and Y
 * differing per part. */
#define SIM_VL53_DEFAULT_PART_ID(sensor)                                                           \
    (0x9A6B1C2D3E070000ull | (uint64_t)(0x40u + 3u * (unsigned)(sensor)) << 8 |                    \
     (uint64_t)(0x21u + (unsigned)(sensor)))

/* The NVM-read state (sim_vl53_nvm.c): ST's sequence, step by step. */
struct sim_vl53_nvm {
    uint64_t force_us; /* when POWER_FORCE went on */
    uint64_t pdn_us;   /* when the NVM was powered up */
    uint64_t readn_low_us;
    bool powered; /* NVM_CTRL__PDN 1 */
    bool clock;   /* CLK_CTRL1 0x05 */
    bool read_mode;
    bool pulse_set;
    bool readn_low;
    bool data_valid; /* DATAOUT holds the word at `addr` */
    uint8_t addr;
    uint8_t ctrl[0x16]; /* 0x0780..0x0795 as written */
    uint8_t data[4];
};

/* A result the model wrote to its result block (for checks from outside). */
struct sim_vl53_published {
    bool valid;
    uint16_t distance_mm;
    uint8_t range_status; /* ULD code from the source */
    uint8_t raw_status;   /* the raw code actually published (forced, VHV missing, ...) */
    uint8_t stream_count;
    uint32_t sample_index;
    uint64_t time_us;
};

struct sim_vl53_stats {
    uint32_t measurements;      /* completed ranges, dropouts included */
    uint32_t published;         /* results written to the result block */
    uint32_t skipped;           /* measurements skipped in bulk (see SIM_VL53_MAX_CATCH_UP) */
    uint32_t overruns;          /* published while the previous interrupt was still pending */
    uint32_t dropouts;          /* the source said present = false: no result, no interrupt */
    uint32_t protocol_errors;   /* accesses a real part would not make sense of (see .c) */
    uint32_t readonly_writes;   /* writes to registers the model treats as read-only (ignored) */
    uint32_t unmappable_status; /* source status with no raw code: published as raw 0 (ULD 255) */
    uint32_t refused_starts;    /* starts that produce nothing (see sim_vl53_refusal) */
    uint32_t no_vhv_results;    /* results published with raw 3: VHV step not done */
    uint32_t power_ups;         /* XSHUT rises and injected resets */
    uint32_t injected_resets;
    uint32_t address_changes;
    uint32_t starts;
    uint32_t stops;
    uint32_t clears;
    uint32_t nvm_words;           /* NVM words read out (READN pulses in ST's sequence) */
    uint32_t nvm_violations;      /* NVM-read accesses out of ST's sequence (NACKed; also counted
                                     as protocol errors) */
    uint32_t nvm_nacks;           /* accesses NACKed by the nvm_unreadable defect */
    uint32_t temperature_updates; /* ST's temperature update run to its end ([ULD]) */
};

enum sim_vl53_drdy_stuck { SIM_VL53_DRDY_FREE, SIM_VL53_DRDY_STUCK_HIGH, SIM_VL53_DRDY_STUCK_LOW };

/* Why the last start produces no data ready (SIM_VL53_RANGES: it ranges). */
enum sim_vl53_refusal {
    SIM_VL53_RANGES = 0,
    SIM_VL53_NO_BLOCK,   /* 0x2D..0x87 not all written since power-up, or 0x81 / 0x85 / 0x46
                            without what makes the part range */
    SIM_VL53_BAD_TIMING, /* mode registers inconsistent, or a timeout pair in no ULD table */
};

struct sim_vl53 {
    struct sim_vl53_config cfg;
    struct sim_clock *clock;
    struct sim_range_source source;
    uint8_t regs[SIM_VL53_REG_SPACE];
    bool powered;
    bool booted;
    uint64_t power_up_us;
    uint8_t address;
    uint16_t index; /* register index auto-increment pointer */
    bool ranging;
    uint64_t range_start_us;
    uint64_t budget_us;
    uint64_t period_us;
    uint64_t completed;     /* measurements completed since the start */
    uint64_t next_event_us; /* boot end or next measurement (SIM_CLOCK_NEVER: none); may be
                               early, never late: sim_vl53_update does nothing before it */
    uint32_t next_sample_index;
    bool stream_started; /* since power-up: the count does not restart at a start */
    uint8_t stream_count;
    uint8_t block_written[(0x87u - 0x2Du) / 8u + 1u]; /* bit k: 0x2D + k written */
    uint8_t vhv_stage; /* 0 none, 1 a range completed, 2 stopped after it, 3 done */
    bool vhv_bound_ok; /* in stage 2: 0x0008 = 0x09 written */
    bool vhv_init_ok;  /* in stage 2: 0x000B = 0x00 written */
    /* ST's temperature update on a calibrated part: 1 after 0x0008 = 0x81, 2 after
     * 0x000B = 0x92, 3 once started (the VHV step runs again: vhv_stage from 0). */
    uint8_t temp_update;
    bool started_since_boot; /* FIRMWARE__SYSTEM_STATUS: 0x01 until the first start */
    enum sim_vl53_refusal refusal;
    uint32_t forced_left; /* results still to publish with forced_raw / forced_mm */
    uint8_t forced_raw;
    uint16_t forced_mm;
    bool irq_pending;
    enum sim_vl53_drdy_stuck drdy;
    bool source_done; /* the source had no more samples: ranging produces nothing */
    int source_error; /* first negative code from the source (0: none) */
    struct sim_vl53_published published[2]; /* [0] newest */
    struct sim_vl53_nvm nvm;
    struct sim_vl53_stats stats;
};

/* A model on `clock` reading `source` (NULL or ops NULL: a constant 100 mm, valid).
 * Powered (and booting) at once if cfg->powered_at_start or !cfg->xshut_wired. Registers
 * itself as a clock listener, so it runs whenever simulated time advances. */
void sim_vl53_init(struct sim_vl53 *dev, const struct sim_vl53_config *cfg, struct sim_clock *clock,
                   const struct sim_range_source *source);

/* The model as a bus target. */
struct sim_i2c_target sim_vl53_target(struct sim_vl53 *dev);

/* Wire XSHUT (output of the MCU) and GPIO1 (input of the MCU) on `gpio`; pins may be
 * >= SIM_GPIO_PINS to leave one unwired. Also sets the pins' idle level. 0 or -1. */
int sim_vl53_wire(struct sim_vl53 *dev, struct sim_gpio *gpio, uint16_t xshut_pin,
                  uint16_t gpio1_pin);

/* XSHUT level change (what the GPIO model calls). */
void sim_vl53_set_xshut(struct sim_vl53 *dev, bool high);

/* GPIO1 level now (high when unpowered: the line's pull-up). */
bool sim_vl53_gpio1_level(struct sim_vl53 *dev);

/* Backdoor: apply a device fault (SIM_FAULT_RESET, _DRDY_HIGH, _DRDY_LOW) now. */
bool sim_vl53_inject(struct sim_vl53 *dev, enum sim_fault_kind kind);

/* Bring the model up to the clock's time (boot, measurements). */
void sim_vl53_update(struct sim_vl53 *dev);

/* Backdoor: the next `count` results are published with raw RESULT__RANGE_STATUS `raw`
 * (low 5 bits, e.g. 1, 2, 17 hardware faults, 4 no target, 7 wrap) and distance `mm`
 * instead of the source's (the source is still consumed). */
void sim_vl53_force_results(struct sim_vl53 *dev, uint8_t raw, uint16_t mm, uint32_t count);

/* The identity the part serves from its NVM (cfg.part_id or its default). */
uint64_t sim_vl53_part_id(const struct sim_vl53 *dev);

/* Backdoor: a register as the bus would read it (no side effects, no statistics). */
uint8_t sim_vl53_peek(struct sim_vl53 *dev, uint16_t reg);

#endif /* SIM_VL53_H */
