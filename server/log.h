/* log.h - the daemon's one log sink: stderr, one line per message, with a timestamp and a level.
 *   2025-01-31 12:00:00.123 [notice] listening on http://127.0.0.1:8080/
 * Levels (STYLE.md Sec. 7): error, warn, notice, info, debug. libwebsockets' own messages are routed
 * here too (srv_log_hook_lws). Safe to call from any thread: each line is written with one
 * fwrite under the stream lock. */
#ifndef MESHSTEER_SERVER_LOG_H
#define MESHSTEER_SERVER_LOG_H

enum { SRV_LOG_ERROR = 0, SRV_LOG_WARN, SRV_LOG_NOTICE, SRV_LOG_INFO, SRV_LOG_DEBUG };

void srv_log_set_level(int level);
int srv_log_get_level(void);
/* "error" | "warn" | "notice" | "info" | "debug" -> SRV_LOG_*; -1 when unknown. */
int srv_log_level_parse(const char *name);
const char *srv_log_level_name(int level);
void srv_log(int level, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Routes libwebsockets' log through srv_log, at a mask matching the current level. Call again
 * after srv_log_set_level. */
void srv_log_hook_lws(void);

#endif
