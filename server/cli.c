/* cli.c - usage errors, terminal progress and option parsing for the meshsteer tool. */
#include "cli.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

static int vfail(const char *cmd, int status, const char *fmt, va_list ap)
{
    fprintf(stderr, "meshsteer %s: ", cmd);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    return status;
}

int cli_usage_error(const char *cmd, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int r = vfail(cmd, CLI_EXIT_USAGE, fmt, ap);
    va_end(ap);
    return r;
}

int cli_fail(const char *cmd, int status, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int r = vfail(cmd, status, fmt, ap);
    va_end(ap);
    return r;
}

static int progress_shown;

void cli_progress(void *ud, const char *stage, double fraction)
{
    if (!isatty(STDERR_FILENO))
        return;
    int pct = (int)lround(fraction * 100.0);
    if (pct < 0)
        pct = 0;
    if (pct > 100)
        pct = 100;
    fprintf(stderr, "\r\033[K%s: %s %3d%%", ud ? (const char *)ud : "meshsteer", stage, pct);
    fflush(stderr);
    progress_shown = 1;
}

void cli_progress_done(void)
{
    if (progress_shown && isatty(STDERR_FILENO)) {
        fputs("\r\033[K", stderr);
        fflush(stderr);
    }
    progress_shown = 0;
}

int cli_parse_double(const char *cmd, const char *opt, const char *s, double *out)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || end == s || *end || !isfinite(v)) {
        cli_usage_error(cmd, "%s: '%s' is not a number", opt, s);
        return -1;
    }
    *out = v;
    return 0;
}

int cli_parse_int(const char *cmd, const char *opt, const char *s, int *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < -2147483647L || v > 2147483647L) {
        cli_usage_error(cmd, "%s: '%s' is not an integer", opt, s);
        return -1;
    }
    *out = (int)v;
    return 0;
}

int cli_has_suffix(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && strcasecmp(s + a - b, suffix) == 0;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

void cli_percentiles(double *v, int n, double *median, double *p99)
{
    if (n <= 0) {
        *median = *p99 = 0;
        return;
    }
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    *median = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
    int k = (int)ceil(0.99 * n) - 1;
    if (k < 0)
        k = 0;
    if (k >= n)
        k = n - 1;
    *p99 = v[k];
}

#include "cli_markers.h"

int cli_parse_up(const char *s)
{
    static const struct {
        const char *name;
        int up;
    } t[] = {{"auto", MDL_UP_AUTO}, {"x", MDL_UP_X},     {"y", MDL_UP_Y},     {"z", MDL_UP_Z},
             {"-x", MDL_UP_NEG_X},  {"-y", MDL_UP_NEG_Y}, {"-z", MDL_UP_NEG_Z}};
    for (size_t i = 0; i < sizeof t / sizeof *t; i++)
        if (strcasecmp(s, t[i].name) == 0)
            return t[i].up;
    return -1;
}

int cli_marker_option(const char *cmd, const char *opt, const char *arg, mdl_marker_opts *mo)
{
    if (!strcmp(opt, "marker-scale")) {
        if (cli_parse_double(cmd, "--marker-scale", arg, &mo->scale))
            return -1;
        if (!(mo->scale > 0)) {
            cli_usage_error(cmd, "--marker-scale must be positive");
            return -1;
        }
        return 0;
    }
    if ((mo->up = cli_parse_up(arg)) < 0) {
        cli_usage_error(cmd, "--marker-up: '%s' is not one of x y z -x -y -z", arg);
        return -1;
    }
    return 0;
}

int cli_print_json(void *cjson_object)
{
    char *js = cJSON_Print(cjson_object);
    cJSON_Delete(cjson_object);
    if (!js)
        return -ENOMEM;
    puts(js);
    free(js);
    return 0;
}
