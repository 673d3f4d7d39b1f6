/* drv_err.h - the one formatter of error messages inside drivers/ (STYLE.md Sec. 4): writes into
 * the caller's `err` buffer (DRV_ERR_LEN bytes, may be NULL) and returns `code`. */
#ifndef MESHSTEER_DRV_ERR_H
#define MESHSTEER_DRV_ERR_H

int drv__err(char *err, int code, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

#endif
