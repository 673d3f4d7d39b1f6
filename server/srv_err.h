/* srv_err.h - the one formatter of error messages for server/ (STYLE.md Sec. 4): writes into the
 * caller's `err` buffer (SRV_ERR_LEN bytes, may be NULL) and returns `code`, so that callers can
 * write `return srv_err(err, -EINVAL, "%s:%d: ...", ...)`. */
#ifndef MESHSTEER_SRV_ERR_H
#define MESHSTEER_SRV_ERR_H

#ifndef SRV_ERR_LEN
#define SRV_ERR_LEN 512
#endif

int srv_err(char *err, int code, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

#endif
