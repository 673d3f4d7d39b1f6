/* labels.c - parsing a label map and binding a model's markers through it (see labels.h).
 *
 * Parsing: the text is copied once, split at ',' into entries and each entry at its one '=' into
 * the model label and the live label (blanks trimmed); the entries point into the copy. Binding:
 * for each model marker, its `source` label is looked up in the map (a linear search; maps are a
 * few dozen entries) and the resulting live label searched among the source's names, the same
 * exact-match rule as mdl_model_bind_markers, which it extends. */
#include "labels.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct srv_labels {
    int n;
    char *buf;            /* the copy of the text, cut into NUL-terminated names */
    const char **model;   /* n */
    const char **live;    /* n */
};

static void set_err(char *err, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void set_err(char *err, const char *fmt, ...)
{
    if (!err)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, MDL_ERR_LEN, fmt, ap);
    va_end(ap);
}

static int is_blank(char c)
{
    return c == ' ' || c == '\t';
}

/* Trims blanks at both ends of s[0..n) in place; returns the start, *n the new length. */
static char *trim(char *s, size_t *n)
{
    while (*n && is_blank(*s)) {
        s++;
        (*n)--;
    }
    while (*n && is_blank(s[*n - 1]))
        (*n)--;
    return s;
}

/* Error about entry k (1-based) whose text is e[0..n) starting at 1-based column col. */
static int entry_err(char *err, int code, int k, const char *e, size_t n, size_t col,
                     const char *why)
{
    int shown = n > 40 ? 37 : (int)n;
    set_err(err, "entry %d '%.*s%s': %s (column %zu)", k, shown, e, n > 40 ? "..." : "", why, col);
    return code;
}

int srv_labels_create(const char *text, srv_labels **out, char *err)
{
    *out = NULL;
    if (!text)
        text = "";
    size_t len = strnlen(text, SRV_LABELS_MAX_LEN);
    if (len >= SRV_LABELS_MAX_LEN) {
        set_err(err, "longer than %d characters", SRV_LABELS_MAX_LEN - 1);
        return -ENAMETOOLONG;
    }
    srv_labels *l = calloc(1, sizeof *l);
    if (!l) {
        set_err(err, "out of memory");
        return -ENOMEM;
    }
    size_t cap = 1; /* entries: commas + 1 */
    for (size_t i = 0; i < len; i++)
        cap += text[i] == ',';
    l->buf = malloc(len + 1);
    l->model = calloc(cap, sizeof *l->model);
    l->live = calloc(cap, sizeof *l->live);
    if (!l->buf || !l->model || !l->live) {
        srv_labels_destroy(l);
        set_err(err, "out of memory");
        return -ENOMEM;
    }
    memcpy(l->buf, text, len + 1);
    size_t blank = 0;
    while (blank < len && is_blank(l->buf[blank]))
        blank++;
    if (blank == len) { /* the empty map */
        *out = l;
        return 0;
    }
    int rc = 0;
    size_t pos = 0;
    for (int k = 1; pos <= len && rc == 0; k++) {
        char *e = l->buf + pos;
        size_t n = 0;
        while (pos + n < len && e[n] != ',')
            n++;
        size_t col = pos + 1, next = pos + n + 1;
        /* the entry as the user wrote it, for messages (text is unmodified) */
        const char *shown = text + pos;
        char *eq = memchr(e, '=', n);
        for (size_t i = 0; i < n; i++) {
            unsigned char c = (unsigned char)e[i];
            if ((c < 0x20 && !is_blank(e[i])) || c == 0x7f) {
                set_err(err, "entry %d: control character 0x%02x in a label (column %zu)", k, c,
                        col + i);
                rc = -EINVAL;
                break;
            }
        }
        if (rc)
            break;
        if (!eq || memchr(eq + 1, '=', n - (size_t)(eq + 1 - e))) {
            rc = entry_err(err, -EINVAL, k, shown, n, col, "expected MODEL=LABEL");
            break;
        }
        size_t nm = (size_t)(eq - e), nl = n - nm - 1;
        char *m = trim(e, &nm), *v = trim(eq + 1, &nl);
        if (!nm) {
            rc = entry_err(err, -EINVAL, k, shown, n, col, "empty model label before '='");
            break;
        }
        if (!nl) {
            rc = entry_err(err, -EINVAL, k, shown, n, col + (size_t)(eq - e) + 1,
                           "empty live label after '='");
            break;
        }
        if (nm >= MDL_NAME_LEN || nl >= MDL_NAME_LEN) {
            char why[96];
            snprintf(why, sizeof why, "%s label longer than %d characters",
                     nm >= MDL_NAME_LEN ? "model" : "live", MDL_NAME_LEN - 1);
            rc = entry_err(err, -ENAMETOOLONG, k, shown, n,
                           nm >= MDL_NAME_LEN ? col + (size_t)(m - e) : col + (size_t)(v - e), why);
            break;
        }
        m[nm] = '\0';
        v[nl] = '\0';
        for (int j = 0; j < l->n; j++)
            if (!strcmp(l->model[j], m)) {
                char why[MDL_NAME_LEN + 64];
                snprintf(why, sizeof why, "model label '%s' is already mapped by entry %d", m,
                         j + 1);
                rc = entry_err(err, -EINVAL, k, shown, n, col + (size_t)(m - e), why);
                break;
            }
        if (rc)
            break;
        l->model[l->n] = m;
        l->live[l->n] = v;
        l->n++;
        pos = next;
    }
    if (rc) {
        srv_labels_destroy(l);
        return rc;
    }
    *out = l;
    return 0;
}

void srv_labels_destroy(srv_labels *l)
{
    if (!l)
        return;
    free(l->buf);
    free(l->model);
    free(l->live);
    free(l);
}

int srv_labels_count(const srv_labels *l)
{
    return l ? l->n : 0;
}

const char *srv_labels_model(const srv_labels *l, int i)
{
    return l->model[i];
}

const char *srv_labels_live(const srv_labels *l, int i)
{
    return l->live[i];
}

static int find_entry(const srv_labels *l, const char *model_label)
{
    for (int j = 0; l && j < l->n; j++)
        if (!strcmp(l->model[j], model_label))
            return j;
    return -1;
}

const char *srv_labels_lookup(const srv_labels *l, const char *model_label)
{
    int j = find_entry(l, model_label);
    return j >= 0 ? l->live[j] : model_label;
}

static int find_name(const char *const *names, int count, const char *want)
{
    for (int j = 0; j < count; j++)
        if (names[j] && !strcmp(names[j], want))
            return j;
    return -1;
}

int srv_labels_bind(const srv_labels *l, const mdl_model_info *info, const char *const *names,
                    int count, int *map, srv_labels_warn_fn warn, void *ud)
{
    if (count < 0 || (count > 0 && !names))
        return -EINVAL;
    int missing = 0;
    for (int i = 0; i < info->nmarkers; i++) {
        map[i] = find_name(names, count, srv_labels_lookup(l, info->markers[i].source));
        missing += map[i] < 0;
    }
    for (int j = 0; warn && j < srv_labels_count(l); j++) {
        char msg[3 * MDL_NAME_LEN + 128];
        int used = 0;
        for (int i = 0; i < info->nmarkers && !used; i++)
            used = !strcmp(info->markers[i].source, l->model[j]);
        if (!used) {
            snprintf(msg, sizeof msg,
                     "label map entry %d '%s=%s': no marker of the model has the label '%s'; "
                     "the entry is unused",
                     j + 1, l->model[j], l->live[j], l->model[j]);
            warn(ud, msg);
        } else if (find_name(names, count, l->live[j]) < 0) {
            snprintf(msg, sizeof msg,
                     "label map entry %d '%s=%s': the source has no marker '%s'; the model's '%s' "
                     "stays unbound",
                     j + 1, l->model[j], l->live[j], l->live[j], l->model[j]);
            warn(ud, msg);
        }
    }
    return missing;
}
