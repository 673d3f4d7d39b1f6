/* fuzz_fakenect.c - fakenect INDEX.txt lines and depth PGMs (drivers/depth/fakenect.c).
 * Input starting with 'P': a depth PGM; otherwise INDEX.txt text, parsed line by line. */
#include "depth/fakenect.h"

#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char err[DRV_ERR_LEN];
    if (size && data[0] == 'P') {
        uint16_t *mm = malloc(640 * 480 * sizeof *mm);
        if (mm)
            (void)drv_fakenect_parse_depth(data, size, "fuzz.pgm", mm, err);
        free(mm);
        return 0;
    }
    size_t i = 0;
    while (i < size) {
        const uint8_t *nl = memchr(data + i, '\n', size - i);
        size_t len = nl ? (size_t)(nl - (data + i)) + 1 : size - i;
        double t;
        uint32_t ts;
        (void)drv_fakenect_parse_index_line((const char *)data + i, len, &t, &ts, err);
        i += len;
    }
    return 0;
}
