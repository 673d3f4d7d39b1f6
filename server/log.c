/* log.c - the one log sink of meshsteerd (see log.h). */
#include "log.h"

#include <libwebsockets.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

static atomic_int log_level = SRV_LOG_NOTICE;

static const char *const level_names[] = {"error", "warn", "notice", "info", "debug"};

void srv_log_set_level(int level)
{
    if (level < SRV_LOG_ERROR)
        level = SRV_LOG_ERROR;
    if (level > SRV_LOG_DEBUG)
        level = SRV_LOG_DEBUG;
    atomic_store(&log_level, level);
}

int srv_log_get_level(void)
{
    return atomic_load(&log_level);
}

int srv_log_level_parse(const char *name)
{
    for (int i = 0; i < 5; i++)
        if (!strcmp(name, level_names[i]))
            return i;
    return -1;
}

const char *srv_log_level_name(int level)
{
    return level >= 0 && level < 5 ? level_names[level] : "?";
}

static void vlog(int level, const char *fmt, va_list ap)
{
    char line[2048];
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    struct tm tm;
    localtime_r(&ts.tv_sec, &tm);
    size_t n = strftime(line, sizeof line, "%Y-%m-%d %H:%M:%S", &tm);
    int w = snprintf(line + n, sizeof line - n, ".%03ld [%s] ", ts.tv_nsec / 1000000,
                     srv_log_level_name(level));
    if (w > 0)
        n += (size_t)w;
    if (n < sizeof line) {
        w = vsnprintf(line + n, sizeof line - n, fmt, ap);
        n = w < 0 ? n : n + (size_t)w;
    }
    if (n > sizeof line - 2)
        n = sizeof line - 2;
    while (n > 0 && line[n - 1] == '\n') /* lws messages end in a newline */
        n--;
    line[n++] = '\n';
    fwrite(line, 1, n, stderr);
}

void srv_log(int level, const char *fmt, ...)
{
    if (level > atomic_load(&log_level))
        return;
    va_list ap;
    va_start(ap, fmt);
    vlog(level, fmt, ap);
    va_end(ap);
}

static void lws_emit(int lws_level, const char *line)
{
    int level = lws_level & LLL_ERR    ? SRV_LOG_ERROR
              : lws_level & LLL_WARN   ? SRV_LOG_WARN
              : lws_level & LLL_NOTICE ? SRV_LOG_INFO /* lws notices are chatty */
                                       : SRV_LOG_DEBUG;
    srv_log(level, "lws: %s", line);
}

void srv_log_hook_lws(void)
{
    int mask = LLL_ERR | LLL_WARN;
    if (srv_log_get_level() >= SRV_LOG_INFO)
        mask |= LLL_NOTICE;
    if (srv_log_get_level() >= SRV_LOG_DEBUG)
        mask |= LLL_INFO;
    lws_set_log_level(mask, lws_emit);
}
