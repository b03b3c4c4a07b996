/* ELF loading for the twin: the program headers' loadable bytes at their physical (load)
 * addresses, as `flash` (openocd "program FILE.elf") writes them into the part's flash. */
#include "twin_elf.h"

#include <elf.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>

int twin_elf_load(const char *path, uint8_t *flash, uint32_t flash_base, uint32_t flash_size,
                  struct twin_elf_info *info, char *err, size_t errlen) {
    memset(info, 0, sizeof *info);
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        snprintf(err, errlen, "%s: %s", path, strerror(errno));
        return -1;
    }
    fseek(f, 0, SEEK_END);
    const long size = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *buf = size > 0 ? malloc((size_t)size) : NULL;
    if (buf == NULL || fread(buf, 1, (size_t)size, f) != (size_t)size) {
        snprintf(err, errlen, "%s: cannot read", path);
        free(buf);
        fclose(f);
        return -1;
    }
    fclose(f);
    int rc = -1;
    Elf32_Ehdr eh;
    if ((size_t)size < sizeof eh) {
        snprintf(err, errlen, "%s: too short for an ELF header", path);
        goto out;
    }
    memcpy(&eh, buf, sizeof eh);
    if (memcmp(eh.e_ident, ELFMAG, SELFMAG) != 0 || eh.e_ident[EI_CLASS] != ELFCLASS32 ||
        eh.e_ident[EI_DATA] != ELFDATA2LSB || eh.e_machine != EM_ARM) {
        snprintf(err, errlen, "%s: not a 32-bit little-endian ARM ELF file", path);
        goto out;
    }
    if (eh.e_phentsize != sizeof(Elf32_Phdr) ||
        (uint64_t)eh.e_phoff + (uint64_t)eh.e_phnum * sizeof(Elf32_Phdr) > (uint64_t)size) {
        snprintf(err, errlen, "%s: program header table out of the file", path);
        goto out;
    }
    info->entry = eh.e_entry;
    for (unsigned i = 0; i < eh.e_phnum; ++i) {
        Elf32_Phdr ph;
        memcpy(&ph, buf + eh.e_phoff + i * sizeof ph, sizeof ph);
        if (ph.p_type != PT_LOAD || ph.p_filesz == 0u) {
            continue; /* nothing to program (.bss, .stack) */
        }
        if ((uint64_t)ph.p_offset + ph.p_filesz > (uint64_t)size) {
            snprintf(err, errlen, "%s: segment %u data out of the file", path, i);
            goto out;
        }
        if (ph.p_paddr < flash_base ||
            (uint64_t)ph.p_paddr + ph.p_filesz > (uint64_t)flash_base + flash_size) {
            snprintf(err, errlen,
                     "%s: segment %u loads at 0x%08x..0x%08x, outside flash 0x%08x..0x%08x", path,
                     i, ph.p_paddr, ph.p_paddr + ph.p_filesz, flash_base, flash_base + flash_size);
            goto out;
        }
        memcpy(flash + (ph.p_paddr - flash_base), buf + ph.p_offset, ph.p_filesz);
        info->segments++;
        info->bytes += ph.p_filesz;
    }
    if (info->segments == 0u) {
        snprintf(err, errlen, "%s: no loadable segment", path);
        goto out;
    }
    rc = 0;
out:
    free(buf);
    return rc;
}
