/* control.c - validation of /stream control messages and their replies (see control.h). */
#include "control.h"
#include "encode.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

static const struct {
    const char *type;
    int kind;
    const char *field; /* the one field it takes besides "type" and "id", or NULL */
} kinds[] = {
    {"encoding", SRV_CTL_ENCODING, "encoding"},
    {"pause", SRV_CTL_PAUSE, NULL},
    {"resume", SRV_CTL_RESUME, NULL},
    {"seek", SRV_CTL_SEEK, "frame"},
    {"speed", SRV_CTL_SPEED, "speed"},
    {"ping", SRV_CTL_PING, NULL},
};

const int srv_source_controls[SRV_SOURCE_CONTROLS] = {SRV_CTL_PAUSE, SRV_CTL_RESUME, SRV_CTL_SEEK,
                                                      SRV_CTL_SPEED};

void srv_controls_text(unsigned bits, char *buf, size_t len)
{
    size_t at = 0;
    if (len)
        buf[0] = '\0';
    for (int i = 0; i < SRV_SOURCE_CONTROLS && at < len; i++)
        if (bits & SRV_CTL_BIT(srv_source_controls[i])) {
            int w = snprintf(buf + at, len - at, "%s%s", at ? ", " : "",
                             srv_control_name(srv_source_controls[i]));
            at += w > 0 ? (size_t)w : 0;
        }
}

const char *srv_control_name(int kind)
{
    for (size_t i = 0; i < sizeof kinds / sizeof kinds[0]; i++)
        if (kinds[i].kind == kind)
            return kinds[i].type;
    return NULL;
}

/* The length of the UTF-8 sequence at s (n bytes left), 0 when it is not a valid one. */
static size_t utf8_seq(const unsigned char *s, size_t n)
{
    if (s[0] < 0x80)
        return 1;
    size_t len = s[0] >= 0xC2 && s[0] <= 0xDF ? 2 : s[0] >= 0xE0 && s[0] <= 0xEF ? 3
               : s[0] >= 0xF0 && s[0] <= 0xF4 ? 4 : 0;
    if (!len || len > n)
        return 0;
    for (size_t i = 1; i < len; i++)
        if ((s[i] & 0xC0) != 0x80)
            return 0;
    if ((s[0] == 0xE0 && s[1] < 0xA0) || (s[0] == 0xED && s[1] > 0x9F) || /* overlong, surrogate */
        (s[0] == 0xF0 && s[1] < 0x90) || (s[0] == 0xF4 && s[1] > 0x8F))  /* overlong, > 10FFFF */
        return 0;
    return len;
}

int srv__utf8_valid(const char *s, size_t n)
{
    for (size_t i = 0; i < n;) {
        size_t k = utf8_seq((const unsigned char *)s + i, n - i);
        if (!k)
            return 0;
        i += k;
    }
    return 1;
}

size_t srv__utf8_copy(char *dst, size_t n, const char *src)
{
    size_t len = strlen(src), o = 0;
    for (size_t i = 0; i < len;) {
        size_t k = utf8_seq((const unsigned char *)src + i, len - i);
        const char *c = k ? src + i : "?";
        size_t w = k ? k : 1;
        if (o + w >= n)
            break;
        memcpy(dst + o, c, w);
        o += w;
        i += k ? k : 1;
    }
    dst[o] = '\0';
    return o;
}

static int fail(const char **code, const char *c, char *msg, size_t msglen, const char *text)
{
    *code = c;
    srv__utf8_copy(msg, msglen, text);
    return -1;
}

int srv_control_parse(const char *txt, size_t len, srv_control *out, const char **code, char *msg,
                      size_t msglen)
{
    memset(out, 0, sizeof *out);
    char m[256];
    if (len == 0)
        return fail(code, "malformed", msg, msglen, "empty message");
    if (memchr(txt, '\0', len))
        return fail(code, "malformed", msg, msglen, "NUL byte in message");
    /* lws checks text frames (LWS_SERVER_OPTION_VALIDATE_UTF8); this parser does not rely on it,
     * as the id and field names it echoes must be text */
    if (!srv__utf8_valid(txt, len))
        return fail(code, "malformed", msg, msglen, "message is not valid UTF-8");
    const char *end = NULL;
    cJSON *j = cJSON_ParseWithLengthOpts(txt, len, &end, 0);
    if (!j) {
        size_t at = end && end >= txt ? (size_t)(end - txt) : 0;
        snprintf(m, sizeof m, "not valid JSON (at byte %zu)", at);
        return fail(code, "malformed", msg, msglen, m);
    }
    /* trailing non-space after the value */
    for (const char *p = end ? end : txt + len; p < txt + len; p++)
        if (*p != ' ' && *p != '\n' && *p != '\r' && *p != '\t') {
            cJSON_Delete(j);
            snprintf(m, sizeof m, "trailing data after the JSON value (at byte %zu)",
                     (size_t)(p - txt));
            return fail(code, "malformed", msg, msglen, m);
        }
    int r = -1;
    if (!cJSON_IsObject(j)) {
        r = fail(code, "malformed", msg, msglen, "expected a JSON object");
        goto done;
    }
    const cJSON *id = cJSON_GetObjectItemCaseSensitive(j, "id");
    if (id) {
        if (cJSON_IsNumber(id) && isfinite(id->valuedouble)) {
            snprintf(out->id, sizeof out->id, "%.17g", id->valuedouble);
        } else if (cJSON_IsString(id) && strlen(id->valuestring) <= 64) {
            char *s = cJSON_PrintUnformatted(id);
            if (s && strlen(s) < sizeof out->id)
                snprintf(out->id, sizeof out->id, "%s", s);
            cJSON_free(s);
        }
        if (!out->id[0]) {
            r = fail(code, "bad_field", msg, msglen,
                     "field 'id' must be a number or a string of at most 64 bytes");
            goto done;
        }
    }
    const cJSON *type = cJSON_GetObjectItemCaseSensitive(j, "type");
    if (!cJSON_IsString(type)) {
        r = fail(code, "bad_field", msg, msglen, "field 'type' (a string) is required");
        goto done;
    }
    int k = -1;
    for (size_t i = 0; i < sizeof kinds / sizeof kinds[0]; i++)
        if (!strcmp(type->valuestring, kinds[i].type))
            k = (int)i;
    if (k < 0) {
        snprintf(m, sizeof m,
                 "unknown type (known: encoding, pause, resume, seek, speed, ping)");
        r = fail(code, "unknown_type", msg, msglen, m);
        goto done;
    }
    out->kind = kinds[k].kind;
    out->type = kinds[k].type;
    /* every field must be known */
    for (const cJSON *f = j->child; f; f = f->next) {
        if (!f->string || (strcmp(f->string, "type") && strcmp(f->string, "id") &&
                           !(kinds[k].field && !strcmp(f->string, kinds[k].field)))) {
            char name[65]; /* at most 64 bytes of it, whole characters */
            srv__utf8_copy(name, sizeof name, f->string ? f->string : "");
            snprintf(m, sizeof m, "unknown field '%s' for type '%s'", name, out->type);
            r = fail(code, "bad_field", msg, msglen, m);
            goto done;
        }
    }
    const cJSON *v = kinds[k].field ? cJSON_GetObjectItemCaseSensitive(j, kinds[k].field) : NULL;
    if (kinds[k].field && !v) {
        snprintf(m, sizeof m, "field '%s' is required for type '%s'", kinds[k].field, out->type);
        r = fail(code, "bad_field", msg, msglen, m);
        goto done;
    }
    switch (out->kind) {
    case SRV_CTL_ENCODING:
        if (!cJSON_IsString(v) || (out->encoding = srv_encoding_parse(v->valuestring)) < 0) {
            r = fail(code, "bad_field", msg, msglen,
                     "field 'encoding' must be \"float32\", \"int16\" or \"params\"");
            goto done;
        }
        break;
    case SRV_CTL_SEEK:
        if (!cJSON_IsNumber(v) || !(v->valuedouble >= 0) || v->valuedouble > 2147483647.0 ||
            v->valuedouble != floor(v->valuedouble)) {
            r = fail(code, "bad_field", msg, msglen,
                     "field 'frame' must be a whole number in [0, 2147483647]");
            goto done;
        }
        out->value = v->valuedouble;
        break;
    case SRV_CTL_SPEED:
        /* its range is the source's (DRV_SPEED_MIN ... DRV_SPEED_MAX, drivers.h), checked in one
         * place for this message and the source's speed= option: drv_source_control */
        if (!cJSON_IsNumber(v) || !isfinite(v->valuedouble)) {
            r = fail(code, "bad_field", msg, msglen, "field 'speed' must be a number");
            goto done;
        }
        out->value = v->valuedouble;
        break;
    default:
        break;
    }
    r = 0;
done:
    cJSON_Delete(j);
    return r;
}

static size_t finish(char *buf, cJSON *o, const srv_control *c)
{
    if (c && c->id[0])
        cJSON_AddRawToObject(o, "id", c->id);
    size_t n = 0;
    if (o && cJSON_PrintPreallocated(o, buf, SRV_REPLY_LEN, 0))
        n = strlen(buf);
    else
        n = (size_t)snprintf(buf, SRV_REPLY_LEN,
                             "{\"type\":\"error\",\"code\":\"internal\",\"message\":\"reply\"}");
    cJSON_Delete(o);
    return n;
}

size_t srv_reply_ack(char *buf, const srv_control *c, int64_t seq)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "type", "ack");
    cJSON_AddStringToObject(o, "request", c->type ? c->type : "");
    if (seq >= 0)
        cJSON_AddNumberToObject(o, "seq", (double)seq);
    return finish(buf, o, c);
}

size_t srv_reply_pong(char *buf, const srv_control *c, uint64_t server_us)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "type", "pong");
    cJSON_AddNumberToObject(o, "server_us", (double)server_us);
    return finish(buf, o, c);
}

size_t srv_reply_error(char *buf, const char *code, const char *message, const srv_control *c)
{
    char m[256];
    srv__utf8_copy(m, sizeof m, message); /* bounded, so the reply always fits; UTF-8 */
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "type", "error");
    cJSON_AddStringToObject(o, "code", code);
    cJSON_AddStringToObject(o, "message", m);
    if (c && c->type)
        cJSON_AddStringToObject(o, "request", c->type);
    return finish(buf, o, c);
}
