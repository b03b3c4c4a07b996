/* RCC (reset and clock control, RM0351 §6) and the flash interface's ACR (RM0351 §3.7.1)
 * of the twin: oscillator ready bits, the main PLL, the SYSCLK switch, the peripheral clock
 * enables. */
#include "twin.h"

/* RCC register offsets and reset values: RM0351 §6.4 (register map table §6.4.32). */
#define RCC_CR       0x00u
#define RCC_ICSCR    0x04u
#define RCC_CFGR     0x08u
#define RCC_PLLCFGR  0x0Cu
#define RCC_CIER     0x18u
#define RCC_CIFR     0x1Cu
#define RCC_CICR     0x20u
#define RCC_AHB1RSTR 0x28u
#define RCC_AHB1ENR  0x48u
#define RCC_AHB2ENR  0x4Cu
#define RCC_AHB3ENR  0x50u
#define RCC_APB1ENR1 0x58u
#define RCC_APB1ENR2 0x5Cu
#define RCC_APB2ENR  0x60u
#define RCC_CCIPR    0x88u
#define RCC_BDCR     0x90u
#define RCC_CSR      0x94u

#define CR_MSION  (1u << 0)
#define CR_MSIRDY (1u << 1)
#define CR_HSION  (1u << 8)
#define CR_HSIRDY (1u << 10)
#define CR_PLLON  (1u << 24)
#define CR_PLLRDY (1u << 25)
#define CSR_RMVF  (1u << 23)
#define CSR_FLAGS 0xFF000000u /* reset flags, cleared by RMVF */

/* DS10198 "HSI16 oscillator characteristics": t_su(HSI16) 1.2 us max (0.8 typical). */
#define HSI_STARTUP_PS 1200000u
/* DS10198 "PLL characteristics": t_LOCK (PLL lock time) 15 us typical, 40 us max. */
#define PLL_LOCK_PS 40000000u

/* RCC_PLLCFGR fields (RM0351 §6.4.4): PLLSRC[1:0], PLLM[6:4] (M = PLLM + 1), PLLN[14:8],
 * the output enables PLLPEN (16), PLLQEN (20), PLLREN (24), PLLR[26:25] (R = 2, 4, 6, 8). */
#define PLLCFGR_ENABLES ((1u << 16) | (1u << 20) | (1u << 24))
#define PLLCFGR_PLLREN  (1u << 24)

void twin_rcc_reset(struct twin *t, bool power_on) {
    struct twin_rcc *r = &t->rcc;
    const uint32_t flags = power_on ? 0x0C000000u /* BORRSTF | PINRSTF */ : r->csr & CSR_FLAGS;
    const bool broken = r->hsi_broken;
    *r = (struct twin_rcc){0};
    r->hsi_broken = broken;
    r->cr = 0x00000063u; /* MSION, MSIRDY, MSIRANGE = 6 (4 MHz) */
    r->icscr = 0x10000000u;
    r->cfgr = 0u; /* SW = SWS = 00: MSI */
    r->pllcfgr = 0x00001000u;
    r->ahb1enr = 0x00000100u;     /* FLASHEN */
    r->csr = 0x00000600u | flags; /* MSISRANGE = 6 */
    r->hsi_ready_ps = UINT64_MAX;
    r->pll_ready_ps = UINT64_MAX;
}

bool twin_rcc_clock_on(const struct twin *t, uint32_t base) {
    const struct twin_rcc *r = &t->rcc;
    if (base >= TWIN_GPIO_BASE && base < TWIN_GPIO_BASE + 0x400u * TWIN_GPIO_PORTS) {
        return (r->ahb2enr & (1u << ((base - TWIN_GPIO_BASE) / 0x400u))) != 0u; /* GPIOxEN */
    }
    if (base == TWIN_I2C1_BASE) {
        return (r->apb1enr1 & (1u << 21)) != 0u; /* I2C1EN */
    }
    if (base == TWIN_USART2_BASE) {
        return (r->apb1enr1 & (1u << 17)) != 0u; /* USART2EN */
    }
    if (base == TWIN_ADC_BASE) {
        return (r->ahb2enr & (1u << 13)) != 0u; /* ADCEN */
    }
    return true;
}

static uint32_t cr_now(struct twin *t) {
    struct twin_rcc *r = &t->rcc;
    if (r->hsi_ready_ps != UINT64_MAX && twin_svc_now_ps(&t->svc) >= r->hsi_ready_ps) {
        r->cr |= CR_HSIRDY;
    }
    if (r->pll_ready_ps != UINT64_MAX && twin_svc_now_ps(&t->svc) >= r->pll_ready_ps) {
        r->cr |= CR_PLLRDY;
    }
    return r->cr;
}

uint32_t twin_rcc_read(struct twin *t, uint32_t off) {
    struct twin_rcc *r = &t->rcc;
    switch (off) {
    case RCC_CR:
        if ((r->cr & CR_HSION) != 0u && (r->cr & CR_HSIRDY) == 0u &&
            r->hsi_ready_ps != UINT64_MAX) {
            twin_svc_warp_to(&t->svc, r->hsi_ready_ps); /* a ready poll: skip to the ready edge */
        }
        if ((r->cr & CR_PLLON) != 0u && (r->cr & CR_PLLRDY) == 0u &&
            r->pll_ready_ps != UINT64_MAX) {
            twin_svc_warp_to(&t->svc, r->pll_ready_ps); /* the lock poll likewise */
        }
        return cr_now(t);
    case RCC_ICSCR:
        return r->icscr;
    case RCC_CFGR:
        return r->cfgr;
    case RCC_PLLCFGR:
        return r->pllcfgr;
    case RCC_CIER:
    case RCC_CIFR:
        return 0u;
    case RCC_AHB1ENR:
        return r->ahb1enr;
    case RCC_AHB2ENR:
        return r->ahb2enr;
    case RCC_AHB3ENR:
        return r->ahb3enr;
    case RCC_APB1ENR1:
        return r->apb1enr1;
    case RCC_APB1ENR2:
        return r->apb1enr2;
    case RCC_APB2ENR:
        return r->apb2enr;
    case RCC_CCIPR:
        return r->ccipr;
    case RCC_BDCR:
        return r->bdcr;
    case RCC_CSR:
        return r->csr;
    default:
        twin_svc_violation(&t->svc, "RCC register", off, "RCC offset the twin does not model");
        return 0u;
    }
}

/* RM0351 §3.3.3 Table 12 "Number of wait states according to CPU clock (HCLK) frequency",
 * voltage range 1 (the reset range; the twin models no other): 0 WS up to 16 MHz, then one
 * more per 16 MHz up to 4 WS at 80 MHz. */
static uint32_t latency_needed(uint32_t hz) {
    return hz <= 16000000u ? 0u : (hz - 1u) / 16000000u;
}

/* The PLL's VCO output from RCC_PLLCFGR (RM0351 §6.4.4): the source PLLSRC (MSI or HSI16,
 * ready; HSE is not modelled) divided by M must be 4..16 MHz, N 8..86, the VCO 64..344 MHz.
 * 0 and a violation if not: such a PLL never locks in the twin. */
static uint32_t pll_vco_hz(struct twin *t) {
    const uint32_t c = t->rcc.pllcfgr;
    const uint32_t cr = cr_now(t);
    uint32_t in = 0;
    if ((c & 3u) == 1u && (cr & CR_MSIRDY) != 0u) {
        in = TWIN_MSI_HZ;
    } else if ((c & 3u) == 2u && (cr & CR_HSIRDY) != 0u) {
        in = TWIN_HSI16_HZ;
    }
    const uint32_t vin = in / (((c >> 4) & 7u) + 1u);
    const uint32_t n = (c >> 8) & 0x7Fu;
    const char *why = NULL;
    if (in == 0u) {
        why = "PLL enabled with its source (PLLSRC) off, not ready, or HSE (not modelled)";
    } else if (vin < 4000000u || vin > 16000000u) {
        why = "PLL input (source / M) outside 4..16 MHz (RM0351 §6.4.4 PLLM)";
    } else if (n < 8u || n > 86u || vin * n < 64000000u || vin * n > 344000000u) {
        why = "PLLN outside 8..86 or VCO outside 64..344 MHz (RM0351 §6.4.4 PLLN)";
    }
    if (why != NULL) {
        twin_svc_violation(&t->svc, "RCC_CR.PLLON", c, why);
        return 0u;
    }
    return vin * n;
}

/* The twin's I2C1 timing is TIMINGR at a 16 MHz kernel clock: with I2C1SEL = PCLK1 (00,
 * RM0351 §6.4.27) a SYSCLK from the PLL would change the bus timing the firmware computed.
 * (The reset clock with PCLK1 is left alone: the model tests run I2C1 that way.) */
static void check_i2c_kernel(struct twin *t, uint32_t sysclk_hz) {
    if (sysclk_hz > 16000000u && ((t->rcc.ccipr >> 12) & 3u) == 0u &&
        (t->rcc.apb1enr1 & (1u << 21)) != 0u) {
        twin_svc_violation(&t->svc, "RCC_CCIPR.I2C1SEL", t->rcc.ccipr,
                           "I2C1 clocked from PCLK1 while SYSCLK is not 16 MHz (the twin's "
                           "I2C timing assumes a 16 MHz kernel clock: select HSI16)");
    }
}

/* RM0351 §6.2.6 "Clock source switching" and RCC_CFGR SW/SWS: the switch takes effect when
 * the selected oscillator is ready; SWS then reports it. The PLL (SW = 11) needs PLLRDY and
 * its R output enabled (PLLREN), at most 80 MHz (RM0351 §6.4.4 PLLR). */
static void clock_switch(struct twin *t, uint32_t sw) {
    struct twin_rcc *r = &t->rcc;
    uint32_t hz = 0;
    if (sw == 0u && (cr_now(t) & CR_MSIRDY) != 0u) {
        hz = TWIN_MSI_HZ;
    } else if (sw == 1u && (cr_now(t) & CR_HSIRDY) != 0u) {
        hz = TWIN_HSI16_HZ;
    } else if (sw == 3u && (cr_now(t) & CR_PLLRDY) != 0u) {
        if ((r->pllcfgr & PLLCFGR_PLLREN) == 0u) {
            twin_svc_violation(&t->svc, "RCC_CFGR.SW", sw, "PLL selected with PLLREN = 0");
            return;
        }
        hz = r->pll_r_hz;
        if (hz > 80000000u) {
            twin_svc_violation(&t->svc, "RCC_CFGR.SW", sw, "PLLCLK above 80 MHz");
            return;
        }
    } else if (sw == 2u) {
        twin_svc_violation(&t->svc, "RCC_CFGR.SW", sw, "HSE is not modelled by the twin");
        return;
    }
    if (hz == 0u) {
        return; /* not ready: SWS keeps the old source (the firmware's poll must time out) */
    }
    /* RM0351 §3.3.3 "Increasing the CPU frequency": LATENCY first, then the clock. */
    if ((t->flash_if.acr & 7u) < latency_needed(hz)) {
        twin_svc_violation(&t->svc, "RCC_CFGR.SW", sw,
                           "SYSCLK raised before FLASH_ACR.LATENCY (RM0351 §3.3.3 Table 12)");
    }
    check_i2c_kernel(t, hz);
    r->cfgr = (r->cfgr & ~0xCu) | (sw << 2);
    twin_svc_set_sysclk(&t->svc, hz);
}

/* RCC_CR.PLLON (RM0351 §6.2.5): on, the PLL locks t_LOCK later if its configuration is
 * valid; off, PLLRDY falls (the twin: at once), never while PLLCLK is SYSCLK. */
static void pll_on_off(struct twin *t, bool was_on, bool on) {
    struct twin_rcc *r = &t->rcc;
    if (on && !was_on) {
        const uint32_t vco = pll_vco_hz(t);
        r->pll_r_hz = vco / (2u * (((r->pllcfgr >> 25) & 3u) + 1u));
        r->pll_ready_ps = vco != 0u ? twin_svc_now_ps(&t->svc) + PLL_LOCK_PS : UINT64_MAX;
    } else if (!on && was_on) {
        if ((r->cfgr & 0xCu) == 0xCu) {
            twin_svc_violation(&t->svc, "RCC_CR.PLLON", r->cr, "PLL off while it is SYSCLK");
        }
        r->cr &= ~CR_PLLRDY;
        r->pll_ready_ps = UINT64_MAX;
    }
}

/* RCC_PLLCFGR (RM0351 §6.2.5 "to modify the PLL configuration"): PLLON = 0 and PLLRDY = 0
 * first; with the PLL on only the output enables may change, PLLREN not while PLLCLK is
 * SYSCLK (§6.4.4). */
static void pllcfgr_write(struct twin *t, uint32_t v) {
    struct twin_rcc *r = &t->rcc;
    const uint32_t changed = v ^ r->pllcfgr;
    if ((cr_now(t) & (CR_PLLON | CR_PLLRDY)) != 0u && (changed & ~PLLCFGR_ENABLES) != 0u) {
        twin_svc_violation(&t->svc, "RCC_PLLCFGR", v,
                           "PLL configuration changed while the PLL is on (RM0351 §6.2.5)");
        return;
    }
    if ((changed & PLLCFGR_PLLREN) != 0u && (r->cfgr & 0xCu) == 0xCu) {
        twin_svc_violation(&t->svc, "RCC_PLLCFGR.PLLREN", v, "PLLREN changed while PLL is SYSCLK");
        return;
    }
    r->pllcfgr = v;
}

void twin_rcc_write(struct twin *t, uint32_t off, uint32_t v) {
    struct twin_rcc *r = &t->rcc;
    switch (off) {
    case RCC_CR: {
        const uint32_t ro = CR_MSIRDY | CR_HSIRDY | (1u << 17) | CR_PLLRDY | (1u << 27);
        const bool hsi_was = (r->cr & CR_HSION) != 0u;
        const bool pll_was = (r->cr & CR_PLLON) != 0u;
        r->cr = (r->cr & ro) | (v & ~ro);
        if ((v & CR_HSION) != 0u && !hsi_was) {
            r->hsi_ready_ps =
                r->hsi_broken ? UINT64_MAX : twin_svc_now_ps(&t->svc) + HSI_STARTUP_PS;
        } else if ((v & CR_HSION) == 0u) {
            if ((r->cfgr & 0xCu) == 0x4u) {
                twin_svc_violation(&t->svc, "RCC_CR.HSION", v,
                                   "HSI16 switched off while it is SYSCLK");
            }
            if (pll_was && (r->pllcfgr & 3u) == 2u) {
                twin_svc_violation(&t->svc, "RCC_CR.HSION", v,
                                   "HSI16 switched off while it feeds the PLL");
            }
            r->cr &= ~CR_HSIRDY;
            r->hsi_ready_ps = UINT64_MAX;
        }
        pll_on_off(t, pll_was, (v & CR_PLLON) != 0u);
        if ((v & CR_MSION) == 0u && (r->cfgr & 0xCu) == 0u) {
            twin_svc_violation(&t->svc, "RCC_CR.MSION", v, "MSI switched off while it is SYSCLK");
        }
        break;
    }
    case RCC_ICSCR:
        r->icscr = v;
        break;
    case RCC_CFGR:
        r->cfgr = (r->cfgr & 0xCu) | (v & ~0xCu);
        if (((v >> 4) & 0xFu) != 0u || ((v >> 8) & 0x3Fu) != 0u) {
            twin_svc_violation(&t->svc, "RCC_CFGR", v,
                               "AHB/APB prescalers other than /1 are not modelled by the twin");
        }
        clock_switch(t, v & 3u);
        break;
    case RCC_PLLCFGR:
        pllcfgr_write(t, v);
        break;
    case RCC_CIER:
    case RCC_CICR:
        break;
    case RCC_AHB1ENR:
        r->ahb1enr = v;
        break;
    case RCC_AHB2ENR:
        r->ahb2enr = v;
        break;
    case RCC_AHB3ENR:
        r->ahb3enr = v;
        break;
    case RCC_APB1ENR1:
        r->apb1enr1 = v;
        check_i2c_kernel(t, t->sysclk_hz);
        break;
    case RCC_APB1ENR2:
        r->apb1enr2 = v;
        break;
    case RCC_APB2ENR:
        r->apb2enr = v;
        break;
    case RCC_CCIPR:
        /* I2C1SEL (bits 13:12): the twin's I2C1 timing assumes HSI16 (10b) or PCLK1 (00b)
         * running at 16 MHz. */
        r->ccipr = v;
        check_i2c_kernel(t, t->sysclk_hz);
        break;
    case RCC_BDCR:
        r->bdcr = v;
        break;
    case RCC_CSR:
        r->csr = (r->csr & CSR_FLAGS) | (v & ~CSR_FLAGS);
        if ((v & CSR_RMVF) != 0u) {
            r->csr &= ~CSR_FLAGS;
        }
        break;
    default:
        twin_svc_violation(&t->svc, "RCC register", off, "RCC offset the twin does not model");
        break;
    }
}

uint32_t twin_flash_if_read(struct twin *t, uint32_t off) {
    if (off == 0u) {
        return t->flash_if.acr;
    }
    twin_svc_violation(&t->svc, "FLASH register", off,
                       "flash interface register the twin does not model");
    return 0u;
}

void twin_flash_if_write(struct twin *t, uint32_t off, uint32_t v) {
    if (off == 0u) {
        t->flash_if.acr = v;
        if ((v & 7u) < latency_needed(t->sysclk_hz)) {
            twin_svc_violation(&t->svc, "FLASH_ACR", v,
                               "LATENCY too low for SYSCLK (RM0351 §3.3.3 Table 12)");
        }
        return;
    }
    twin_svc_violation(&t->svc, "FLASH register", off,
                       "flash interface register the twin does not model");
}
