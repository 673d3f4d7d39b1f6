/* drv_err.c - see drv_err.h. */
#include "drv_err.h"
#include "drivers.h"

#include <stdarg.h>
#include <stdio.h>

int drv__err(char *err, int code, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, DRV_ERR_LEN, fmt, ap);
        va_end(ap);
    }
    return code;
}
