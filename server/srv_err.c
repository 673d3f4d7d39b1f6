/* srv_err.c - see srv_err.h. */
#include "srv_err.h"

#include <stdarg.h>
#include <stdio.h>

int srv_err(char *err, int code, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, SRV_ERR_LEN, fmt, ap);
        va_end(ap);
    }
    return code;
}
