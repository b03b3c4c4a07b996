/* The twin's peripheral bus: routes each memory-mapped access to its model, and in strict
 * mode stops on reserved addresses, sub-word accesses and peripherals used unclocked. */
#include "twin.h"

#include <stdio.h>

static bool in(uint32_t addr, uint32_t base, uint32_t size) {
    return addr >= base && addr - base < size;
}

/* RM0351 §6.2 "Clocks": a peripheral's registers are not accessible while its clock is off. */
static bool clocked(struct twin *t, uint32_t base, uint32_t addr, uint32_t value, bool write) {
    if (twin_rcc_clock_on(t, base)) {
        return true;
    }
    char reg[48];
    snprintf(reg, sizeof reg, "%s 0x%08x", write ? "write" : "read", addr);
    twin_svc_violation(&t->svc, reg, value,
                       "peripheral used before its clock is enabled in RCC (RM0351 §6.2, §6.4)");
    return false;
}

static void reserved(struct twin *t, uint32_t addr, uint32_t value, bool write) {
    char reg[48];
    snprintf(reg, sizeof reg, "%s 0x%08x", write ? "write" : "read", addr);
    twin_svc_violation(&t->svc, reg, value,
                       "reserved address or register the twin does not model (RM0351 Table 1)");
}

static bool word_access(struct twin *t, uint32_t addr, unsigned size, uint32_t value) {
    if (size == 4u && (addr & 3u) == 0u) {
        return true;
    }
    char reg[48];
    snprintf(reg, sizeof reg, "%u-byte access 0x%08x", size, addr);
    twin_svc_violation(&t->svc, reg, value,
                       "peripheral registers are accessed as aligned 32-bit words");
    return false;
}

uint32_t twin_bus_read(struct twin *t, uint32_t addr, unsigned size) {
    if (in(addr, TWIN_RECORDS_BASE, TWIN_RECORDS_SIZE)) {
        return twin_flash_mem_read(t, addr - TWIN_RECORDS_BASE, size); /* memory: any size */
    }
    if (size != 4u && !in(addr, TWIN_GPIO_BASE, 0x400u * TWIN_GPIO_PORTS)) {
        word_access(t, addr, size, 0u);
    }
    const uint32_t a = addr & ~3u;
    uint32_t v = 0;
    if (!in(a, 0xE000E000u, 0x1000u)) {
        t->scs_only_since_cvr = false;
    }
    if (in(a, TWIN_RCC_BASE, 0x400u)) {
        v = twin_rcc_read(t, a - TWIN_RCC_BASE);
    } else if (in(a, TWIN_FLASHIF_BASE, 0x400u)) {
        v = twin_flash_read(t, a - TWIN_FLASHIF_BASE);
    } else if (in(a, TWIN_GPIO_BASE, 0x400u * TWIN_GPIO_PORTS)) {
        const unsigned port = (a - TWIN_GPIO_BASE) / 0x400u;
        if (clocked(t, TWIN_GPIO_BASE + 0x400u * port, a, 0u, false)) {
            v = twin_gpio_read(t, port, (a - TWIN_GPIO_BASE) % 0x400u);
        }
    } else if (in(a, TWIN_I2C1_BASE, 0x400u)) {
        if (clocked(t, TWIN_I2C1_BASE, a, 0u, false)) {
            v = twin_i2c_read(t, a - TWIN_I2C1_BASE);
        }
    } else if (in(a, TWIN_USART2_BASE, 0x400u)) {
        if (clocked(t, TWIN_USART2_BASE, a, 0u, false)) {
            v = twin_usart_read(t, a - TWIN_USART2_BASE);
        }
    } else if (in(a, TWIN_IWDG_BASE, 0x400u)) {
        v = twin_iwdg_read(t, a - TWIN_IWDG_BASE);
    } else if (in(a, TWIN_ADC_BASE, 0x400u)) {
        if (clocked(t, TWIN_ADC_BASE, a, 0u, false)) {
            v = twin_adc_read(t, a - TWIN_ADC_BASE);
        }
    } else if (in(a, TWIN_SYSMEM_CAL_PAGE, 0x1000u)) {
        v = twin_adc_sysmem_read(t, a - TWIN_SYSMEM_CAL_PAGE);
    } else if (a == TWIN_DBGMCU_APB1FZR1) {
        v = t->dbgmcu_apb1fzr1;
    } else if (in(a, 0xE000E000u, 0x1000u)) {
        v = twin_scs_read(t, a);
    } else {
        reserved(t, addr, 0u, false);
    }
    if (size < 4u) {
        v = (v >> (8u * (addr & 3u))) & ((1u << (8u * size)) - 1u);
    }
    return v;
}

void twin_bus_write(struct twin *t, uint32_t addr, unsigned size, uint32_t value) {
    if (in(addr, TWIN_RECORDS_BASE, TWIN_RECORDS_SIZE)) {
        twin_flash_mem_write(t, addr - TWIN_RECORDS_BASE, size, value); /* its own rules */
        return;
    }
    const bool gpio = in(addr, TWIN_GPIO_BASE, 0x400u * TWIN_GPIO_PORTS);
    t->scs_only_since_cvr = false;
    if (size != 4u && !gpio) {
        word_access(t, addr, size, value);
        return;
    }
    uint32_t a = addr & ~3u;
    if (gpio && size != 4u) {
        /* RM0351 §8.4: GPIO registers take byte, half-word and word accesses; merge. */
        const unsigned port = (a - TWIN_GPIO_BASE) / 0x400u;
        const uint32_t off = (a - TWIN_GPIO_BASE) % 0x400u;
        const uint32_t shift = 8u * (addr & 3u);
        const uint32_t mask = ((size == 1u) ? 0xFFu : 0xFFFFu) << shift;
        const uint32_t old = off == 0x18u || off == 0x28u ? 0u : twin_gpio_read(t, port, off);
        value = (old & ~mask) | ((value << shift) & mask);
    }
    if (in(a, TWIN_RCC_BASE, 0x400u)) {
        twin_rcc_write(t, a - TWIN_RCC_BASE, value);
    } else if (in(a, TWIN_FLASHIF_BASE, 0x400u)) {
        twin_flash_write(t, a - TWIN_FLASHIF_BASE, value);
    } else if (gpio) {
        const unsigned port = (a - TWIN_GPIO_BASE) / 0x400u;
        if (clocked(t, TWIN_GPIO_BASE + 0x400u * port, a, value, true)) {
            twin_gpio_write(t, port, (a - TWIN_GPIO_BASE) % 0x400u, value);
        }
    } else if (in(a, TWIN_I2C1_BASE, 0x400u)) {
        if (clocked(t, TWIN_I2C1_BASE, a, value, true)) {
            twin_i2c_write(t, a - TWIN_I2C1_BASE, value);
        }
    } else if (in(a, TWIN_USART2_BASE, 0x400u)) {
        if (clocked(t, TWIN_USART2_BASE, a, value, true)) {
            twin_usart_write(t, a - TWIN_USART2_BASE, value);
        }
    } else if (in(a, TWIN_IWDG_BASE, 0x400u)) {
        twin_iwdg_write(t, a - TWIN_IWDG_BASE, value);
    } else if (in(a, TWIN_ADC_BASE, 0x400u)) {
        if (clocked(t, TWIN_ADC_BASE, a, value, true)) {
            twin_adc_write(t, a - TWIN_ADC_BASE, value);
        }
    } else if (in(a, TWIN_SYSMEM_CAL_PAGE, 0x1000u)) {
        twin_svc_violation(&t->svc, "system memory", a, "system memory is read only");
    } else if (a == TWIN_DBGMCU_APB1FZR1) {
        t->dbgmcu_apb1fzr1 = value;
    } else if (in(a, 0xE000E000u, 0x1000u)) {
        twin_scs_write(t, a, value);
    } else {
        reserved(t, addr, value, true);
    }
}
