/*
 * Private to the VL53 driver's files: one call's time budget and its register transfers
 * (vl53_regio.c), the offset registers (vl53_offset.c, over vl53_regio.c), and small
 * helpers on the device's state. The files above them (vl53_boot.c, vl53_config.c,
 * vl53_result.c) call down into these, never into each other except through the public
 * vl53.h (vl53_boot.c and vl53_result.c use the timing facts of vl53_config.c).
 */
#ifndef VL53_INTERNAL_H
#define VL53_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "vl53/vl53.h"

/* Time budget of one call: every transfer gets at most what is left of it. */
struct call {
    struct vl53_dev *dev;
    uint32_t start_us;
    uint32_t budget_us;
};

static inline uint32_t now_us(const struct vl53_dev *dev) {
    return dev->cfg->time.ops->now_us(dev->cfg->time.ctx);
}

static inline void delay_us(const struct vl53_dev *dev, uint32_t us) {
    dev->cfg->time.ops->delay_us(dev->cfg->time.ctx, us);
}

/* True once `now` is at or past `moment` (wrap-safe within half the counter range): the
 * unsigned difference is below 2^31 exactly when (int32_t)(now - moment) >= 0. */
static inline bool time_reached(uint32_t now, uint32_t moment) {
    const uint32_t since = now - moment;
    return since < 0x80000000u;
}

static inline uint32_t or_default(uint32_t value, uint32_t fallback) {
    return value != 0u ? value : fallback;
}

static inline bool dev_ok(const struct vl53_dev *dev) {
    return dev != NULL && dev->cfg != NULL;
}

static inline struct call call_begin(struct vl53_dev *dev, uint32_t budget_us) {
    struct call c = {dev, now_us(dev), budget_us};
    return c;
}

/* The budget of an ordinary call (vl53_call_budget_us()). */
static inline uint32_t call_budget(const struct vl53_dev *dev) {
    return vl53_call_budget_us(dev->cfg);
}

/* Timeout for the next transfer of call `c`, or 0 when its budget is spent. */
uint32_t vl53_call_transfer_timeout(const struct call *c);

/* Register transfers within call `c`'s budget: HAL_ERR_TIMEOUT once it is spent, else the
 * bus's result unchanged. */
int vl53_call_read(const struct call *c, uint8_t addr, uint16_t reg, uint8_t *data, size_t len);
int vl53_call_write(const struct call *c, uint8_t addr, uint16_t reg, const uint8_t *data,
                    size_t len);
/* One byte to register `reg` of the device at its current address. */
int vl53_call_write_byte(const struct call *c, uint16_t reg, uint8_t value);

/* Data ready from GPIO__TIO_HV_STATUS for interrupt polarity `polarity`. */
int vl53_read_data_ready(const struct call *c, enum vl53_polarity polarity, bool *ready);

/* The offsets a config may carry: the part-to-part field's 13 bits hold them (vl53_offset.c). */
bool vl53_offsets_valid(const struct vl53_offsets *offsets);

/* Write dev->cfg->offsets to 0x1E..0x23 in one transfer and read them back (vl53_offset.c):
 * HAL_OK, the bus's error, HAL_ERR_DEVICE if the part holds another value (two read-backs
 * alike, the model ID right) or else HAL_ERR_CORRUPT; dev->offset_mismatch_reg names the
 * register on either. */
int vl53_write_offsets(const struct call *c);

/* The part is (or will be after a reset) stopped: no ranging, no VHV range, no stream. */
void vl53_forget_ranging(struct vl53_dev *dev);

#endif /* VL53_INTERNAL_H */
