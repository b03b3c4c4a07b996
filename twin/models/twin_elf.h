/* Loading a firmware ELF into the twin's flash as the `flash` target programs it. */
#ifndef TWIN_TWIN_ELF_H
#define TWIN_TWIN_ELF_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

struct twin_elf_info {
    uint32_t entry;
    unsigned segments; /* loadable segments with file bytes */
    uint32_t bytes;    /* bytes programmed */
};

/* Copy every PT_LOAD segment with file bytes to its physical address in `flash` (the image
 * of [flash_base, flash_base + flash_size)). 0, or -1 with the reason in err. */
int twin_elf_load(const char *path, uint8_t *flash, uint32_t flash_base, uint32_t flash_size,
                  struct twin_elf_info *info, char *err, size_t errlen);

#endif /* TWIN_TWIN_ELF_H */
