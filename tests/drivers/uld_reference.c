/* The ULD's register image for a mode and budget (see uld_reference.h). */
#include "uld_reference.h"

#include <stddef.h>

/* Rows of eight registers from 0x2D, as the Linux driver lays them out. */
const uint8_t uld_default_configuration[ULD_BLOCK_LEN] = {
    0x00, 0x00, 0x00, 0x01, 0x02, 0x00, 0x02, 0x08, /* 0x2D..0x34 */
    0x00, 0x08, 0x10, 0x01, 0x01, 0x00, 0x00, 0x00, /* 0x35..0x3C */
    0x00, 0xFF, 0x00, 0x0F, 0x00, 0x00, 0x00, 0x00, /* 0x3D..0x44 */
    0x00, 0x20, 0x0B, 0x00, 0x00, 0x02, 0x0A, 0x21, /* 0x45..0x4C */
    0x00, 0x00, 0x05, 0x00, 0x00, 0x00, 0x00, 0xC8, /* 0x4D..0x54 */
    0x00, 0x00, 0x38, 0xFF, 0x01, 0x00, 0x08, 0x00, /* 0x55..0x5C */
    0x00, 0x01, 0xCC, 0x0F, 0x01, 0xF1, 0x0D, 0x01, /* 0x5D..0x64 */
    0x68, 0x00, 0x80, 0x08, 0xB8, 0x00, 0x00, 0x00, /* 0x65..0x6C */
    0x00, 0x0F, 0x89, 0x00, 0x00, 0x00, 0x00, 0x00, /* 0x6D..0x74 */
    0x00, 0x00, 0x01, 0x0F, 0x0D, 0x0E, 0x0E, 0x00, /* 0x75..0x7C */
    0x00, 0x02, 0xC7, 0xFF, 0x9B, 0x00, 0x00, 0x00, /* 0x7D..0x84 */
    0x01, 0x00, 0x00,                               /* 0x85..0x87 */
};

struct budget {
    uint16_t ms, a, b;
};
/* VL53L1X_SetTimingBudgetInMs, short then long mode. */
static const struct budget short_budgets[] = {
    {15, 0x001D, 0x0027},  {20, 0x0051, 0x006E},  {33, 0x00D6, 0x006E}, {50, 0x01AE, 0x01E8},
    {100, 0x02E1, 0x0388}, {200, 0x03E1, 0x0496}, {500, 0x0591, 0x05C1}};
static const struct budget long_budgets[] = {{20, 0x001E, 0x0022},  {33, 0x0060, 0x006E},
                                             {50, 0x00AD, 0x00C6},  {100, 0x01CC, 0x01EA},
                                             {200, 0x02D9, 0x02F8}, {500, 0x048F, 0x04A4}};

static void put(uint8_t *image, uint16_t reg, uint8_t value) {
    image[reg - ULD_BLOCK_FIRST] = value;
}

static void put16(uint8_t *image, uint16_t reg, uint16_t value) {
    put(image, reg, (uint8_t)(value >> 8));
    put(image, (uint16_t)(reg + 1u), (uint8_t)(value & 0xFFu));
}

bool uld_reference_image(bool long_mode, uint16_t budget_ms, uint32_t period_ms, uint16_t osc,
                         bool active_high, bool pads_at_avdd, uint8_t image[ULD_BLOCK_LEN]) {
    const struct budget *table = long_mode ? long_budgets : short_budgets;
    const size_t count = long_mode ? sizeof long_budgets / sizeof long_budgets[0]
                                   : sizeof short_budgets / sizeof short_budgets[0];
    const struct budget *b = NULL;
    for (size_t i = 0; i < count; ++i) {
        if (table[i].ms == budget_ms) {
            b = &table[i];
        }
    }
    if (b == NULL) {
        return false;
    }
    /* SensorInit: the table, with the pad bits the board needs. */
    for (size_t i = 0; i < ULD_BLOCK_LEN; ++i) {
        image[i] = uld_default_configuration[i];
    }
    if (pads_at_avdd) {
        image[0x2E - ULD_BLOCK_FIRST] |= 0x01u;
        image[0x2F - ULD_BLOCK_FIRST] |= 0x01u;
    }
    /* SetInterruptPolarity: 0x30 = (0x30 & 0xEF) | !active_high << 4. */
    put(image, 0x30,
        (uint8_t)((image[0x30 - ULD_BLOCK_FIRST] & 0xEFu) | (active_high ? 0u : 0x10u)));
    /* SetDistanceMode. */
    put(image, 0x4B, long_mode ? 0x0A : 0x14);
    put(image, 0x60, long_mode ? 0x0F : 0x07);
    put(image, 0x63, long_mode ? 0x0D : 0x05);
    put(image, 0x69, long_mode ? 0xB8 : 0x38);
    put16(image, 0x78, long_mode ? 0x0F0D : 0x0705);
    put16(image, 0x7A, long_mode ? 0x0E0E : 0x0606);
    /* SetTimingBudgetInMs. */
    put16(image, 0x5E, b->a);
    put16(image, 0x61, b->b);
    /* SetInterMeasurementInMs: (uint32_t)(ClockPLL * ms * 1.075), in exact integers. */
    const uint64_t imp = (uint64_t)(osc & 0x3FFu) * period_ms * 1075u / 1000u;
    put16(image, 0x6C, (uint16_t)(imp >> 16));
    put16(image, 0x6E, (uint16_t)(imp & 0xFFFFu));
    /* ClearInterrupt, StartRanging. */
    put(image, 0x86, 0x01);
    put(image, 0x87, 0x40);
    return true;
}

int uld_temperature_update_check(const struct uld_write *writes, size_t n) {
    static const struct uld_write sequence[] = {
        {0x0008u, 0x81u}, {0x000Bu, 0x92u}, {0x0087u, 0x40u}, {0x0086u, 0x01u},
        {0x0087u, 0x00u}, {0x0008u, 0x09u}, {0x000Bu, 0x00u},
    };
    const size_t steps = sizeof sequence / sizeof sequence[0];
    size_t at = 0;
    for (size_t step = 0; step < steps; ++step, ++at) {
        if (at < n && step == 2u && writes[at].reg == 0x0086u && writes[at].value == 0x01u) {
            ++at; /* the stale-interrupt clear, directly before the start */
        }
        if (at >= n) {
            return (int)n;
        }
        if (writes[at].reg != sequence[step].reg || writes[at].value != sequence[step].value) {
            return (int)at;
        }
    }
    return at == n ? -1 : (int)at;
}
