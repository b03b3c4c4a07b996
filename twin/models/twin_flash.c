/* The twin's flash program/erase interface and record pages (RM0351 §3.3.5-3.3.7, §3.7), strict,
 * with power-cut injection. */
#include <stdio.h>
#include <string.h>

#include "twin.h"

/* Register offsets (RM0351 §3.7) and bits. */
#define KEYR       0x08u
#define SR         0x10u
#define CR         0x14u
#define ECCR       0x18u
#define KEY1       0x45670123u /* §3.3.5 "Unlocking the Flash memory" */
#define KEY2       0xCDEF89ABu
#define SR_EOP     (1u << 0)
#define SR_PROGERR (1u << 3)
#define SR_PGAERR  (1u << 5)
#define SR_SIZERR  (1u << 6)
#define SR_PGSERR  (1u << 7)
#define SR_ERRORS                                                                                  \
    0xC3FAu /* OPERR PROGERR WRPERR PGAERR SIZERR PGSERR MISERR FASTERR RDERR OPTVERR */
#define SR_BSY    (1u << 16)
#define CR_PG     (1u << 0)
#define CR_PER    (1u << 1)
#define CR_PNB    (0xFFu << 3)
#define CR_BKER   (1u << 11)
#define CR_STRT   (1u << 16)
#define CR_LOCK   (1u << 31)
#define ECCR_ECCD (1u << 31)
#define ECCR_ECCC (1u << 30)
#define EXC_NMI   2u
/* DS10198 "Flash memory characteristics", typical: page erase 22.02 ms, 64-bit program
 * 81.69 us. */
#define ERASE_PS   22020000000ull
#define PROGRAM_PS 81690000ull

void twin_flash_reset(struct twin *t) {
    struct twin_flash *f = &t->flash_pe;
    f->sr = 0u;
    f->cr = CR_LOCK | (1u << 30); /* reset value 0xC000 0000: LOCK, OPTLOCK (§3.7.6) */
    f->eccr = 0u;
    f->key_step = 0u;
    f->locked_until_reset = false;
    f->busy_until_ps = 0u;
    f->first_pending = false;
}

static uint8_t *records(struct twin *t) {
    return &t->flash[TWIN_RECORDS_BASE - TWIN_FLASH_BASE];
}

static bool busy(struct twin *t) {
    return twin_svc_now_ps(&t->svc) < t->flash_pe.busy_until_ps;
}

static void rule(struct twin *t, const char *reg, uint32_t value, const char *text) {
    twin_svc_violation(&t->svc, reg, value, text);
}

/* The next erase or double-word: 1 apply, 0 the power is cut in it (half done, reboot). */
static int next_op(struct twin *t) {
    struct twin_flash *f = &t->flash_pe;
    if (f->cut_after != TWIN_FLASH_NO_CUT && f->ops++ >= f->cut_after) {
        f->cut_after = TWIN_FLASH_NO_CUT;
        ++f->cuts;
        t->reset_pending = true; /* power back at once: the MCU boots again */
        twin_svc_kick(&t->svc);
        return 0;
    }
    return 1;
}

static void set_ecc_bad(struct twin_flash *f, uint32_t dword, bool bad) {
    const uint8_t bit = (uint8_t)(1u << (dword % 8u));
    f->ecc_bad[dword / 8u] =
        (uint8_t)(bad ? f->ecc_bad[dword / 8u] | bit : f->ecc_bad[dword / 8u] & ~bit);
}

static void erase(struct twin *t, uint32_t cr) {
    struct twin_flash *f = &t->flash_pe;
    const uint32_t pnb = (cr & CR_PNB) >> 3;
    if ((cr & CR_BKER) == 0u || pnb < TWIN_RECORDS_PNB ||
        pnb >= TWIN_RECORDS_PNB + TWIN_RECORDS_SIZE / 2048u) {
        rule(t, "FLASH_CR", cr,
             "page erase outside the record pages (bank 2 pages 252-255): "
             "it would erase the image (stm32l476rg.ld)");
        return;
    }
    const int op = next_op(t);
    const uint32_t page = pnb - TWIN_RECORDS_PNB;
    const uint32_t n = op > 0 ? 2048u : 1024u; /* a cut leaves the first half erased */
    memset(&records(t)[page * 2048u], 0xFF, n);
    for (uint32_t d = 0; d < n / 8u; ++d) {
        set_ecc_bad(f, page * 256u + d, false);
    }
    ++f->erases;
    f->sr |= SR_EOP;
    f->busy_until_ps = twin_svc_now_ps(&t->svc) + ERASE_PS;
}

static void write_cr(struct twin *t, uint32_t v) {
    struct twin_flash *f = &t->flash_pe;
    if ((f->cr & CR_LOCK) != 0u) {
        rule(t, "FLASH_CR", v, "written while locked: unlock with KEYR first (RM0351 §3.3.5)");
        return;
    }
    if (busy(t)) {
        rule(t, "FLASH_CR", v, "written while BSY: wait for the operation (RM0351 §3.3.6)");
        return;
    }
    if ((v & CR_STRT) != 0u) {
        if ((v & CR_PER) == 0u || (v & CR_PG) != 0u || (f->sr & SR_ERRORS) != 0u) {
            f->sr |= SR_PGSERR;
            rule(t, "FLASH_CR", v,
                 "STRT without PER alone, or with error flags of an earlier "
                 "operation not cleared (PGSERR, RM0351 §3.3.6)");
            return;
        }
        erase(t, v);
    }
    f->cr = v & ~CR_STRT;
}

static void write_keyr(struct twin *t, uint32_t v) {
    struct twin_flash *f = &t->flash_pe;
    if (f->key_step == 0u && v == KEY1 && !f->locked_until_reset) {
        f->key_step = 1u;
        return;
    }
    if (f->key_step == 1u && v == KEY2) {
        f->cr &= ~CR_LOCK;
    } else {
        f->locked_until_reset = true;
        rule(t, "FLASH_KEYR", v,
             "wrong key sequence: CR stays locked until reset (RM0351 "
             "§3.3.5)");
    }
    f->key_step = 0u;
}

uint32_t twin_flash_read(struct twin *t, uint32_t off) {
    struct twin_flash *f = &t->flash_pe;
    switch (off) {
    case SR:
        if (busy(t)) {
            twin_svc_warp_to(&t->svc, f->busy_until_ps); /* a BSY poll loop: skip it */
            return f->sr | SR_BSY;
        }
        return f->sr;
    case CR:
        return f->cr;
    case ECCR:
        return f->eccr;
    case KEYR:
        return 0u;
    default:
        return twin_flash_if_read(t, off); /* ACR, and the rule for what is not modelled */
    }
}

void twin_flash_write(struct twin *t, uint32_t off, uint32_t v) {
    struct twin_flash *f = &t->flash_pe;
    switch (off) {
    case KEYR:
        write_keyr(t, v);
        break;
    case SR:
        f->sr &= ~(v & (SR_ERRORS | SR_EOP)); /* write 1 to clear (§3.7.5) */
        break;
    case CR:
        write_cr(t, v);
        break;
    case ECCR:
        f->eccr &= ~(v & (ECCR_ECCD | ECCR_ECCC));
        break;
    default:
        twin_flash_if_write(t, off, v);
        break;
    }
}

uint32_t twin_flash_mem_read(struct twin *t, uint32_t off, unsigned size) {
    uint32_t v = 0;
    memcpy(&v, &records(t)[off], size);
    if ((t->flash_pe.ecc_bad[off / 64u] & (1u << ((off / 8u) % 8u))) != 0u) {
        /* two bits wrong: ECCD, the address, and an NMI (RM0351 §3.3.2) */
        t->flash_pe.eccr =
            ECCR_ECCD | (1u << 19) | ((TWIN_RECORDS_BASE - 0x08080000u + off) & 0x7FFF8u);
        twin_svc_set_pending(&t->svc, EXC_NMI, true);
    }
    return v;
}

/* The double-word at `off` (aligned) is erased and readable. */
static bool erased(struct twin *t, uint32_t off) {
    for (unsigned k = 0; k < 8u; ++k) {
        if (records(t)[off + k] != 0xFFu) {
            return false;
        }
    }
    return (t->flash_pe.ecc_bad[off / 64u] & (1u << ((off / 8u) % 8u))) == 0u;
}

static void program(struct twin *t, uint32_t off, uint32_t second) {
    struct twin_flash *f = &t->flash_pe;
    if (!erased(t, off)) {
        f->sr |= SR_PROGERR;
        rule(t, "flash double-word", off, "programmed where not erased (PROGERR, RM0351 §3.3.7)");
        return;
    }
    const uint32_t words[2] = {f->first_word, second};
    const int op = next_op(t);
    memcpy(&records(t)[off], words, op > 0 ? 8u : 4u); /* a cut: half written, ECC wrong */
    set_ecc_bad(f, off / 8u, op == 0);
    ++f->programs;
    f->sr |= SR_EOP;
    f->busy_until_ps = twin_svc_now_ps(&t->svc) + PROGRAM_PS;
}

void twin_flash_mem_write(struct twin *t, uint32_t off, unsigned size, uint32_t v) {
    struct twin_flash *f = &t->flash_pe;
    char reg[40];
    snprintf(reg, sizeof reg, "flash 0x%08x", TWIN_RECORDS_BASE + off);
    if ((f->cr & CR_PG) == 0u || (f->cr & CR_LOCK) != 0u || busy(t)) {
        f->sr |= SR_PGSERR;
        rule(t, reg, v, "flash written without PG set, or while BSY (PGSERR, RM0351 §3.3.7)");
    } else if (size != 4u || (off & 3u) != 0u) {
        f->sr |= SR_SIZERR;
        rule(t, reg, v, "flash programmed by a write that is not a 32-bit word (SIZERR)");
    } else if (!f->first_pending && (off & 7u) == 0u) {
        f->first_pending = true;
        f->first_word = v;
        f->first_off = off;
    } else if (f->first_pending && off == f->first_off + 4u) {
        f->first_pending = false;
        program(t, f->first_off, v);
    } else {
        f->first_pending = false;
        f->sr |= SR_PGAERR;
        rule(t, reg, v, "not the words of one aligned double-word in order (PGAERR, §3.3.7)");
    }
}
