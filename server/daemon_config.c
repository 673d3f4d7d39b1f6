/* daemon_config.c - parsing and validation of meshsteerd's settings (see daemon_config.h). */
#include "srv_err.h"
#include "daemon_config.h"
#include "encode.h"
#include "labels.h"
#include "log.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CFG_MAX_FILE (1u << 20)
#define CFG_MAX_LINE 8192

_Static_assert(sizeof(((srv_config *)0)->labels) == SRV_LABELS_MAX_LEN, "labels size");

void srv_config_defaults(srv_config *c)
{
    memset(c, 0, sizeof *c);
    snprintf(c->listen_host, sizeof c->listen_host, "127.0.0.1");
    c->port = 8080;
    c->max_clients = 256;
    c->max_message = 4096;
    c->idle_timeout = 30;
    c->idle_after = 2.0;
    c->fade = 0.5;
    snprintf(c->origin, sizeof c->origin, "any");
    c->log_level = SRV_LOG_NOTICE;
    c->encoding = SRV_ENC_FLOAT32;
    snprintf(c->subject, sizeof c->subject, "meshsteer");
}

static int set_str(char *dst, size_t cap, const char *key, const char *v, char *err)
{
    size_t n = strlen(v);
    if (n >= cap)
        return srv_err(err, -ENAMETOOLONG, "%s: value longer than %zu bytes", key, cap - 1);
    memcpy(dst, v, n + 1);
    return 0;
}

static int set_int(int *dst, const char *key, const char *v, long lo, long hi, char *err)
{
    char *end;
    errno = 0;
    long x = strtol(v, &end, 10);
    if (end == v || *end || errno)
        return srv_err(err, -EINVAL, "%s: '%s' is not a whole number", key, v);
    if (x < lo || x > hi)
        return srv_err(err, -ERANGE, "%s: %ld outside [%ld, %ld]", key, x, lo, hi);
    *dst = (int)x;
    return 0;
}

static int set_seconds(double *dst, const char *key, const char *v, double lo, double hi,
                       char *err)
{
    char *end;
    errno = 0;
    double x = strtod(v, &end);
    if (end == v || *end || errno || !isfinite(x))
        return srv_err(err, -EINVAL, "%s: '%s' is not a number of seconds", key, v);
    if (x < lo || x > hi)
        return srv_err(err, -ERANGE, "%s: %g outside [%g, %g] seconds", key, x, lo, hi);
    *dst = x;
    return 0;
}

/* [ADDR:]PORT; ADDR may be [v6]. */
static int set_listen(srv_config *c, const char *v, char *err)
{
    char host[256];
    const char *port;
    if (v[0] == '[') {
        const char *close = strchr(v, ']');
        if (!close || close[1] != ':')
            return srv_err(err, -EINVAL, "listen: '%s' (expected [ADDR]:PORT)", v);
        size_t n = (size_t)(close - v - 1);
        if (n == 0 || n >= sizeof host)
            return srv_err(err, -EINVAL, "listen: bad address in '%s'", v);
        memcpy(host, v + 1, n);
        host[n] = '\0';
        port = close + 2;
    } else {
        const char *colon = strrchr(v, ':');
        if (colon) {
            size_t n = (size_t)(colon - v);
            if (n == 0 || n >= sizeof host || memchr(v, ':', n))
                return srv_err(err, -EINVAL, "listen: '%s' (expected ADDR:PORT or PORT)", v);
            memcpy(host, v, n);
            host[n] = '\0';
            port = colon + 1;
        } else {
            snprintf(host, sizeof host, "%s", c->listen_host);
            port = v;
        }
    }
    for (const char *p = host; *p; p++)
        if (!isalnum((unsigned char)*p) && !strchr(".-:_", *p))
            return srv_err(err, -EINVAL, "listen: bad character in address '%s'", host);
    int pn;
    int r = set_int(&pn, "listen port", port, 0, 65535, err);
    if (r)
        return r;
    snprintf(c->listen_host, sizeof c->listen_host, "%s", host);
    c->port = pn;
    return 0;
}

static int set_origin(srv_config *c, const char *v, char *err)
{
    if (!*v)
        return srv_err(err, -EINVAL, "origin: empty (use any, same or a list of origins)");
    if (strcmp(v, "any") && strcmp(v, "same")) {
        /* a comma list of scheme://host[:port] */
        char tmp[sizeof c->origin];
        if (strlen(v) >= sizeof tmp)
            return srv_err(err, -ENAMETOOLONG, "origin: list too long");
        snprintf(tmp, sizeof tmp, "%s", v);
        for (char *save = NULL, *o = strtok_r(tmp, ",", &save); o; o = strtok_r(NULL, ",", &save)) {
            while (*o == ' ')
                o++;
            if (strncmp(o, "http://", 7) && strncmp(o, "https://", 8))
                return srv_err(err, -EINVAL,
                               "origin: '%s' is not any, same or an http(s):// origin", o);
        }
    }
    return set_str(c->origin, sizeof c->origin, "origin", v, err);
}

/* nats://HOST[:PORT][,nats://HOST[:PORT]...]; HOST a name, an IPv4 address or [IPv6]. */
static int set_publish(srv_config *c, const char *v, char *err)
{
    char tmp[sizeof c->publish];
    if (strlen(v) >= sizeof tmp)
        return srv_err(err, -ENAMETOOLONG, "publish: longer than %zu bytes", sizeof tmp - 1);
    snprintf(tmp, sizeof tmp, "%s", v);
    int n = 0;
    for (char *save = NULL, *u = strtok_r(tmp, ",", &save); u; u = strtok_r(NULL, ",", &save)) {
        while (*u == ' ')
            u++;
        if (strncmp(u, "nats://", 7))
            return srv_err(err, -EINVAL, "publish: '%s' is not a nats://HOST:PORT URL", u);
        const char *host = u + 7, *end = host;
        if (*host == '[') {
            end = strchr(host, ']');
            if (!end || end == host + 1)
                return srv_err(err, -EINVAL, "publish: bad IPv6 address in '%s'", u);
            end++;
        } else {
            for (; *end && *end != ':'; end++)
                if (!isalnum((unsigned char)*end) && !strchr(".-_", *end))
                    return srv_err(err, -EINVAL, "publish: bad character in host of '%s'", u);
            if (end == host)
                return srv_err(err, -EINVAL, "publish: no host in '%s'", u);
        }
        if (*end == ':') {
            int port;
            int r = set_int(&port, "publish port", end + 1, 1, 65535, err);
            if (r)
                return r;
        } else if (*end) {
            return srv_err(err, -EINVAL, "publish: '%s' (expected nats://HOST:PORT)", u);
        }
        if (++n > 16)
            return srv_err(err, -E2BIG, "publish: more than 16 servers");
    }
    if (!n && *v)
        return srv_err(err, -EINVAL, "publish: no server URL in '%s'", v);
    return set_str(c->publish, sizeof c->publish, "publish", v, err);
}

/* Dot-separated tokens of [A-Za-z0-9_-]: no wildcard, no empty token, no space. */
static int set_subject(srv_config *c, const char *v, char *err)
{
    size_t n = strlen(v);
    if (!n)
        return srv_err(err, -EINVAL, "subject: empty");
    for (size_t i = 0; i < n; i++) {
        unsigned char ch = (unsigned char)v[i];
        if (ch == '.' ? i == 0 || i + 1 == n || v[i + 1] == '.'
                      : !isalnum(ch) && ch != '-' && ch != '_')
            return srv_err(err, -EINVAL,
                           "subject: '%s' at byte %zu (use dot-separated tokens of letters, "
                           "digits, - and _)", v, i);
    }
    return set_str(c->subject, sizeof c->subject, "subject", v, err);
}

int srv_config_set(srv_config *c, const char *key, const char *v, char *err)
{
    if (!strcmp(key, "model"))
        return *v ? set_str(c->model, sizeof c->model, key, v, err)
                  : srv_err(err, -EINVAL, "model: empty path");
    if (!strcmp(key, "source"))
        return *v ? set_str(c->source, sizeof c->source, key, v, err)
                  : srv_err(err, -EINVAL, "source: empty spec");
    if (!strcmp(key, "listen"))
        return set_listen(c, v, err);
    if (!strcmp(key, "record"))
        return set_str(c->record, sizeof c->record, key, v, err);
    if (!strcmp(key, "max_clients"))
        return set_int(&c->max_clients, key, v, 1, 10000, err);
    if (!strcmp(key, "max_message"))
        return set_int(&c->max_message, key, v, 64, 1 << 20, err);
    if (!strcmp(key, "idle_timeout"))
        return set_int(&c->idle_timeout, key, v, 1, 86400, err);
    if (!strcmp(key, "idle_after"))
        return set_seconds(&c->idle_after, key, v, 0.1, 3600, err);
    if (!strcmp(key, "fade"))
        return set_seconds(&c->fade, key, v, 0, 60, err);
    if (!strcmp(key, "token")) {
        for (const char *p = v; *p; p++)
            if (!isgraph((unsigned char)*p) || strchr("&=#%", *p))
                return srv_err(err, -EINVAL, "token: use printable characters other than & = # %%");
        return set_str(c->token, sizeof c->token, key, v, err);
    }
    if (!strcmp(key, "origin"))
        return set_origin(c, v, err);
    if (!strcmp(key, "web_root"))
        return set_str(c->web_root, sizeof c->web_root, key, v, err);
    if (!strcmp(key, "log_level")) {
        int l = srv_log_level_parse(v);
        if (l < 0)
            return srv_err(err, -EINVAL, "log_level: '%s' (expected error, warn, notice, info, debug)",
                           v);
        c->log_level = l;
        return 0;
    }
    if (!strcmp(key, "labels")) {
        char e[MDL_ERR_LEN];
        srv_labels *l;
        int r = srv_labels_create(v, &l, e);
        if (r)
            return srv_err(err, r, "labels: %s", e);
        srv_labels_destroy(l);
        return set_str(c->labels, sizeof c->labels, key, v, err);
    }
    if (!strcmp(key, "encoding")) {
        int e = srv_encoding_parse(v);
        if (e < 0)
            return srv_err(err, -EINVAL, "encoding: '%s' (expected float32, int16 or params)", v);
        c->encoding = e;
        return 0;
    }
    if (!strcmp(key, "publish"))
        return set_publish(c, v, err);
    if (!strcmp(key, "subject"))
        return set_subject(c, v, err);
    return srv_err(err, -ENOENT,
                   "unknown key '%s' (known: model, source, listen, record, max_clients, "
                   "max_message, idle_timeout, idle_after, fade, token, origin, web_root, "
                   "log_level, encoding, labels, publish, subject)",
                   key);
}

static char *trim(char *s)
{
    while (*s == ' ' || *s == '\t')
        s++;
    size_t n = strlen(s);
    while (n > 0 && (s[n - 1] == ' ' || s[n - 1] == '\t' || s[n - 1] == '\r'))
        s[--n] = '\0';
    return s;
}

int srv_config_parse(srv_config *c, const char *text, size_t len, const char *name, char *err)
{
    srv_config tmp = *c;
    char seen[32][32];
    int seen_line[32];
    int nseen = 0;
    char line[CFG_MAX_LINE];
    size_t pos = 0;
    int lineno = 0;
    char e[SRV_ERR_LEN];
    while (pos < len) {
        lineno++;
        size_t end = pos;
        while (end < len && text[end] != '\n')
            end++;
        size_t n = end - pos;
        if (n >= sizeof line)
            return srv_err(err, -EINVAL, "%s:%d: line longer than %d bytes", name, lineno,
                           CFG_MAX_LINE - 1);
        memcpy(line, text + pos, n);
        line[n] = '\0';
        pos = end + (end < len);
        if (memchr(line, '\0', n))
            return srv_err(err, -EINVAL, "%s:%d: NUL byte in line", name, lineno);
        /* comments: '#' at the start or after whitespace (values such as URLs may hold '#') */
        for (char *h = line; (h = strchr(h, '#')); h++)
            if (h == line || h[-1] == ' ' || h[-1] == '\t') {
                *h = '\0';
                break;
            }
        char *s = trim(line);
        if (!*s)
            continue;
        char *eq = strchr(s, '=');
        if (!eq)
            return srv_err(err, -EINVAL, "%s:%d: expected 'key = value'", name, lineno);
        *eq = '\0';
        char *key = trim(s), *val = trim(eq + 1);
        if (!*key)
            return srv_err(err, -EINVAL, "%s:%d: missing key before '='", name, lineno);
        size_t vl = strlen(val);
        if (vl >= 2 && val[0] == '"' && val[vl - 1] == '"') {
            val[vl - 1] = '\0';
            val++;
        } else if (strchr(val, '"')) {
            return srv_err(err, -EINVAL, "%s:%d: unbalanced quote in value of '%s'", name, lineno,
                           key);
        }
        for (int i = 0; i < nseen; i++)
            if (!strcmp(seen[i], key))
                return srv_err(err, -EINVAL, "%s:%d: '%s' set twice (first on line %d)", name,
                               lineno, key, seen_line[i]);
        int r = srv_config_set(&tmp, key, val, e);
        if (r)
            return srv_err(err, r, "%s:%d: %s", name, lineno, e);
        if (nseen < 32 && strlen(key) < sizeof seen[0]) {
            snprintf(seen[nseen], sizeof seen[0], "%s", key);
            seen_line[nseen++] = lineno;
        }
    }
    *c = tmp;
    return 0;
}

int srv_config_read(srv_config *c, const char *path, char *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return srv_err(err, -errno, "%s: %s", path, strerror(errno));
    char *buf = malloc(CFG_MAX_FILE + 1);
    if (!buf) {
        fclose(f);
        return srv_err(err, -ENOMEM, "%s: out of memory", path);
    }
    size_t n = fread(buf, 1, CFG_MAX_FILE + 1, f);
    int rerr = ferror(f);
    fclose(f);
    int r;
    if (rerr)
        r = srv_err(err, -EIO, "%s: read error", path);
    else if (n > CFG_MAX_FILE)
        r = srv_err(err, -EFBIG, "%s: larger than %u bytes", path, CFG_MAX_FILE);
    else
        r = srv_config_parse(c, buf, n, path, err);
    free(buf);
    return r;
}

int srv_config_validate(const srv_config *c, char *err)
{
    if (!c->model[0])
        return srv_err(err, -EINVAL, "no model (--model FILE or 'model = FILE')");
    if (!c->source[0])
        return srv_err(err, -EINVAL, "no source (--source SPEC or 'source = SPEC')");
    return 0;
}
