/* VL53 driver: the part's own offset registers 0x1E/0x20/0x22 pinned to the recorded state. */
/*
 * Why pin them: the part loads all three from its NVM at every boot ([P2P] in vl53_regs.h),
 * and what ST's drivers then leave there differs (the ULD keeps the NVM values unless
 * SetOffset is called; the full API and Pololu's driver copy the outer offset x 4 into
 * 0x1E at the first start). A calibration made on readings from one such state holds only
 * if every boot gives the same state, so the driver writes it, from the config, at every
 * bring-up, and trusts nothing the part held before.
 */
#include <stddef.h>

#include "hal/hal_err.h"
#include "hal/hal_i2c_reg.h"
#include "vl53/vl53.h"
#include "vl53_internal.h"

bool vl53_offsets_valid(const struct vl53_offsets *offsets) {
    return offsets->part_to_part_qmm >= VL53_PART_TO_PART_MIN_QMM &&
           offsets->part_to_part_qmm <= VL53_PART_TO_PART_MAX_QMM;
}

/* 0x1E..0x23 as written: the 13-bit two's complement of the quarter millimetres (bits 15:13
 * are not part of the field, [P2P]: a part may read them back as 0), then the two 16-bit mm. */
static void offset_block(const struct vl53_offsets *offsets, uint8_t out[VL53_OFFSET_REGS_LEN]) {
    const uint16_t p2p = (uint16_t)((uint16_t)offsets->part_to_part_qmm & VL53_PART_TO_PART_MASK);
    hal_put_be16(&out[0], p2p);
    hal_put_be16(&out[2], (uint16_t)offsets->inner_mm);
    hal_put_be16(&out[4], (uint16_t)offsets->outer_mm);
}

/* The first of the three registers whose bytes in `back` differ from `want`, or 0. */
static uint16_t first_mismatch(const uint8_t *want, const uint8_t *back) {
    static const uint16_t regs[3] = {VL53_REG_ALGO_PART_TO_PART_RANGE_OFFSET_MM,
                                     VL53_REG_MM_CONFIG_INNER_OFFSET_MM,
                                     VL53_REG_MM_CONFIG_OUTER_OFFSET_MM};
    for (size_t i = 0; i < 3u; ++i) {
        if (want[2u * i] != back[2u * i] || want[2u * i + 1u] != back[2u * i + 1u]) {
            return regs[i];
        }
    }
    return 0u;
}

int vl53_write_offsets(const struct call *c) {
    struct vl53_dev *dev = c->dev;
    uint8_t want[VL53_OFFSET_REGS_LEN];
    uint8_t back[VL53_OFFSET_REGS_LEN];
    uint8_t again[VL53_OFFSET_REGS_LEN];
    offset_block(&dev->cfg->offsets, want);
    dev->offset_mismatch_reg = 0u;
    /* One auto-incrementing transfer (the three are consecutive), one read-back. */
    int err = vl53_call_write(c, dev->address, VL53_REG_ALGO_PART_TO_PART_RANGE_OFFSET_MM, want,
                              sizeof want);
    if (err == HAL_OK) {
        err = vl53_call_read(c, dev->address, VL53_REG_ALGO_PART_TO_PART_RANGE_OFFSET_MM, back,
                             sizeof back);
    }
    if (err != HAL_OK) {
        return err;
    }
    const uint16_t reg = first_mismatch(want, back);
    if (reg == 0u) {
        return HAL_OK;
    }
    dev->offset_mismatch_reg = reg;
    /* Tell a part that holds another value (it did not take the write: re-initialising
     * will not help) from reads garbled on the bus: the model ID must read right and the
     * offsets read alike a second time. Only on a mismatch: no cost otherwise. */
    uint8_t id[2];
    err = vl53_call_read(c, dev->address, VL53_REG_IDENTIFICATION_MODEL_ID, id, sizeof id);
    if (err == HAL_OK) {
        err = vl53_call_read(c, dev->address, VL53_REG_ALGO_PART_TO_PART_RANGE_OFFSET_MM, again,
                             sizeof again);
    }
    if (err != HAL_OK) {
        return err;
    }
    const bool bus_sane = hal_get_be16(id) == VL53_MODEL_ID_VL53L1X;
    return bus_sane && first_mismatch(back, again) == 0u ? HAL_ERR_DEVICE : HAL_ERR_CORRUPT;
}

uint16_t vl53_offset_mismatch_register(const struct vl53_dev *dev) {
    return dev_ok(dev) ? dev->offset_mismatch_reg : 0u;
}
