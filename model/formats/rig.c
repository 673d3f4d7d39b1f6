/* rig.c - the rig file: how a marker set is attached to a mesh (DESIGN.md "The rig file").
 *
 * Paper 2012 (Voegele et al.) Sec. 4:  marker graph G -> limbs (paths of markers),
 *   correspondence tau (marker -> mesh vertex) -> markers[i].vertex,  reference edge e_ref -> ref.
 *
 *   { "markers":   [ {"name": "lf_hoof", "vertex": 2080, "source": "LeftHand"}, ... ],
 *     "reference": ["withers", "croup"],            2 names, or 3 (the third fixes the roll)
 *     "limbs":     [ ["withers", "lf_hoof"], ... ] } each a path of >= 2 marker names
 *
 * JSON syntax comes from cJSON; everything else is validated here, and every message names the file
 * and the JSON path of the offending value (`rig.json: markers[3].vertex: ...`). Unknown keys are
 * ignored, so that rigs may carry comments or tool-specific data. mdl_rig_write writes the same
 * format (one marker per line), for `meshsteer rig`.
 */
#include "model.h"
#include "core/util.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RIG_MAX_FILE ((size_t)16 << 20)

/* A string member that fits in MDL_NAME_LEN; `what` is the JSON path for messages. */
static int get_name(const cJSON *v, const char *name, const char *what, char dst[MDL_NAME_LEN],
                    char *err)
{
    if (!cJSON_IsString(v) || !v->valuestring)
        return mdl__err(err, MDL_EFORMAT, "%s: %s: must be a string", name, what);
    size_t n = strlen(v->valuestring);
    if (n == 0)
        return mdl__err(err, MDL_EFORMAT, "%s: %s: must not be empty", name, what);
    if (n >= MDL_NAME_LEN)
        return mdl__err(err, MDL_EFORMAT, "%s: %s: \"%.20s...\" is %zu bytes long (at most %d)", name,
                        what, v->valuestring, n, MDL_NAME_LEN - 1);
    memcpy(dst, v->valuestring, n + 1);
    return 0;
}

static int find_marker(const mdl_rig *r, const char *s)
{
    for (int i = 0; i < r->nmarkers; i++)
        if (strcmp(r->markers[i].name, s) == 0)
            return i;
    return -1;
}

/* A marker reference by name at JSON path `what`: index into r->markers. */
static int get_ref(const mdl_rig *r, const cJSON *v, const char *name, const char *what, int *idx,
                   char *err)
{
    char s[MDL_NAME_LEN];
    int e = get_name(v, name, what, s, err);
    if (e)
        return e;
    *idx = find_marker(r, s);
    if (*idx < 0)
        return mdl__err(err, MDL_EFORMAT, "%s: %s: \"%s\" is not a marker name", name, what, s);
    return 0;
}

static int parse_markers(mdl_rig *r, const cJSON *arr, const char *name, int nv, char *err)
{
    if (!arr)
        return mdl__err(err, MDL_EFORMAT, "%s: markers: missing", name);
    if (!cJSON_IsArray(arr))
        return mdl__err(err, MDL_EFORMAT, "%s: markers: must be an array", name);
    int n = cJSON_GetArraySize(arr);
    if (n < 2)
        return mdl__err(err, MDL_EFORMAT, "%s: markers: %d markers (need at least 2)", name, n);
    r->markers = mdl__calloc((size_t)n, sizeof *r->markers);
    if (!r->markers)
        return mdl__err(err, -ENOMEM, "%s: out of memory", name);
    char what[64];
    int i = 0;
    const cJSON *m;
    cJSON_ArrayForEach(m, arr) {
        mdl_rig_marker *mk = &r->markers[i];
        if (!cJSON_IsObject(m))
            return mdl__err(err, MDL_EFORMAT, "%s: markers[%d]: must be an object", name, i);
        snprintf(what, sizeof what, "markers[%d].name", i);
        const cJSON *v = cJSON_GetObjectItemCaseSensitive(m, "name");
        if (!v)
            return mdl__err(err, MDL_EFORMAT, "%s: %s: missing", name, what);
        int e = get_name(v, name, what, mk->name, err);
        if (e)
            return e;
        if (find_marker(r, mk->name) >= 0)
            return mdl__err(err, MDL_EFORMAT, "%s: %s: \"%s\" is used by markers[%d] already", name,
                            what, mk->name, find_marker(r, mk->name));
        snprintf(what, sizeof what, "markers[%d].source", i);
        v = cJSON_GetObjectItemCaseSensitive(m, "source");
        if (v && !cJSON_IsNull(v)) {
            if ((e = get_name(v, name, what, mk->source, err)) != 0)
                return e;
        } else {
            memcpy(mk->source, mk->name, sizeof mk->source);
        }
        snprintf(what, sizeof what, "markers[%d].vertex", i);
        v = cJSON_GetObjectItemCaseSensitive(m, "vertex");
        if (!v)
            return mdl__err(err, MDL_EFORMAT, "%s: %s: missing", name, what);
        if (!cJSON_IsNumber(v))
            return mdl__err(err, MDL_EFORMAT, "%s: %s: must be a number", name, what);
        double d = v->valuedouble;
        if (!isfinite(d) || d != floor(d))
            return mdl__err(err, MDL_EFORMAT, "%s: %s: %g is not an integer", name, what, d);
        if (d < 0 || d > INT_MAX)
            return mdl__err(err, MDL_EFORMAT, "%s: %s: %.15g is out of range", name, what, d);
        if (nv > 0 && d >= nv)
            return mdl__err(err, MDL_EFORMAT, "%s: %s: %.15g is out of range (mesh has %d vertices)",
                            name, what, d, nv);
        mk->vertex = (int)d;
        r->nmarkers = ++i; /* only complete markers count, so find_marker sees valid names */
    }
    return 0;
}

static int parse_reference(mdl_rig *r, const cJSON *arr, const char *name, char *err)
{
    if (!arr)
        return mdl__err(err, MDL_EFORMAT, "%s: reference: missing", name);
    if (!cJSON_IsArray(arr))
        return mdl__err(err, MDL_EFORMAT, "%s: reference: must be an array of marker names", name);
    int n = cJSON_GetArraySize(arr);
    if (n != 2 && n != 3)
        return mdl__err(err, MDL_EFORMAT, "%s: reference: has %d names (need 2 or 3)", name, n);
    char what[64];
    int i = 0;
    const cJSON *v;
    cJSON_ArrayForEach(v, arr) {
        snprintf(what, sizeof what, "reference[%d]", i);
        int e = get_ref(r, v, name, what, &r->ref[i], err);
        if (e)
            return e;
        for (int j = 0; j < i; j++)
            if (r->ref[j] == r->ref[i])
                return mdl__err(err, MDL_EFORMAT, "%s: %s: \"%s\" is already reference[%d]", name,
                                what, r->markers[r->ref[i]].name, j);
        i++;
    }
    r->nref = n;
    return 0;
}

static int parse_limbs(mdl_rig *r, const cJSON *arr, const char *name, char *err)
{
    if (!arr)
        return mdl__err(err, MDL_EFORMAT, "%s: limbs: missing", name);
    if (!cJSON_IsArray(arr))
        return mdl__err(err, MDL_EFORMAT, "%s: limbs: must be an array of marker-name arrays", name);
    int n = cJSON_GetArraySize(arr);
    if (n < 1)
        return mdl__err(err, MDL_EFORMAT, "%s: limbs: empty (need at least one limb)", name);
    /* count first, so that the index array is allocated once */
    long total = 0;
    int l = 0;
    const cJSON *limb;
    cJSON_ArrayForEach(limb, arr) {
        if (!cJSON_IsArray(limb))
            return mdl__err(err, MDL_EFORMAT, "%s: limbs[%d]: must be an array of marker names", name,
                            l);
        int k = cJSON_GetArraySize(limb);
        if (k < 2)
            return mdl__err(err, MDL_EFORMAT, "%s: limbs[%d]: has %d markers (need at least 2)", name,
                            l, k);
        total += k;
        l++;
    }
    r->limb_off = mdl__calloc((size_t)n + 1, sizeof(int));
    r->limb_idx = mdl__calloc((size_t)total, sizeof(int));
    if (!r->limb_off || !r->limb_idx)
        return mdl__err(err, -ENOMEM, "%s: out of memory", name);
    char what[64];
    int at = 0;
    l = 0;
    cJSON_ArrayForEach(limb, arr) {
        r->limb_off[l] = at;
        int j = 0;
        const cJSON *v;
        cJSON_ArrayForEach(v, limb) {
            snprintf(what, sizeof what, "limbs[%d][%d]", l, j);
            int idx, e = get_ref(r, v, name, what, &idx, err);
            if (e)
                return e;
            for (int q = r->limb_off[l]; q < at; q++)
                if (r->limb_idx[q] == idx)
                    return mdl__err(err, MDL_EFORMAT, "%s: %s: \"%s\" appears twice in this limb",
                                    name, what, r->markers[idx].name);
            r->limb_idx[at++] = idx;
            j++;
        }
        l++;
    }
    r->limb_off[n] = at;
    r->nlimbs = n;
    return 0;
}

int mdl_rig_parse(const char *buf, size_t len, const char *name, int nv, mdl_rig **out, char *err)
{
    *out = NULL;
    if (!name)
        name = "<rig>";
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(buf, len, &end, 0);
    if (!root) {
        /* line and column of the error position cJSON reports */
        long line = 1, col = 1;
        size_t at = end && end >= buf && end <= buf + len ? (size_t)(end - buf) : 0;
        for (size_t i = 0; i < at; i++) {
            if (buf[i] == '\n') {
                line++;
                col = 1;
            } else {
                col++;
            }
        }
        return mdl__err(err, MDL_EFORMAT, "%s:%ld:%ld: invalid JSON", name, line, col);
    }
    while (end && end < buf + len && (*end == ' ' || *end == '\t' || *end == '\r' || *end == '\n'))
        end++;
    mdl_rig *r = calloc(1, sizeof *r);
    int e;
    if (end && end < buf + len)
        e = mdl__err(err, MDL_EFORMAT, "%s: offset %zu: unexpected data after the JSON value", name,
                     (size_t)(end - buf));
    else if (!r)
        e = mdl__err(err, -ENOMEM, "%s: out of memory", name);
    else if (!cJSON_IsObject(root))
        e = mdl__err(err, MDL_EFORMAT, "%s: the top level must be a JSON object", name);
    else if ((e = parse_markers(r, cJSON_GetObjectItemCaseSensitive(root, "markers"), name, nv,
                                err)) == 0 &&
             (e = parse_reference(r, cJSON_GetObjectItemCaseSensitive(root, "reference"), name,
                                  err)) == 0)
        e = parse_limbs(r, cJSON_GetObjectItemCaseSensitive(root, "limbs"), name, err);
    cJSON_Delete(root);
    if (e) {
        mdl_rig_destroy(r);
        return e;
    }
    *out = r;
    return 0;
}

int mdl_rig_read(const char *path, int nv, mdl_rig **out, char *err)
{
    *out = NULL;
    char *buf;
    size_t len;
    int r = mdl__read_file(path, RIG_MAX_FILE, &buf, &len, err);
    if (r)
        return r;
    r = mdl_rig_parse(buf, len, path, nv, out, err);
    free(buf);
    return r;
}

void mdl_rig_destroy(mdl_rig *r)
{
    if (!r)
        return;
    free(r->markers);
    free(r->limb_off);
    free(r->limb_idx);
    free(r);
}

/* One JSON string (escaped by cJSON) into f; 0 or -ENOMEM. */
static int put_string(FILE *f, const char *s)
{
    cJSON *j = cJSON_CreateString(s);
    char *t = j ? cJSON_PrintUnformatted(j) : NULL;
    cJSON_Delete(j);
    if (!t)
        return -ENOMEM;
    fputs(t, f);
    cJSON_free(t);
    return 0;
}

int mdl_rig_write(const char *path, const mdl_rig *r, const char *comment, char *err)
{
    FILE *f = fopen(path, "w");
    if (!f)
        return mdl__err(err, -errno, "%s: %s", path, strerror(errno));
    int e = 0;
    fputs("{\n", f);
    if (comment) {
        fputs("  \"comment\": ", f);
        e |= put_string(f, comment);
        fputs(",\n", f);
    }
    fputs("  \"markers\": [\n", f);
    for (int i = 0; i < r->nmarkers && !e; i++) {
        fputs("    {\"name\": ", f);
        e |= put_string(f, r->markers[i].name);
        fprintf(f, ", \"vertex\": %d, \"source\": ", r->markers[i].vertex);
        e |= put_string(f, r->markers[i].source);
        fprintf(f, "}%s\n", i + 1 < r->nmarkers ? "," : "");
    }
    fputs("  ],\n  \"reference\": [", f);
    for (int i = 0; i < r->nref && !e; i++) {
        e |= put_string(f, r->markers[r->ref[i]].name);
        fputs(i + 1 < r->nref ? ", " : "", f);
    }
    fputs("],\n  \"limbs\": [\n", f);
    for (int l = 0; l < r->nlimbs && !e; l++) {
        fputs("    [", f);
        for (int k = r->limb_off[l]; k < r->limb_off[l + 1] && !e; k++) {
            e |= put_string(f, r->markers[r->limb_idx[k]].name);
            fputs(k + 1 < r->limb_off[l + 1] ? ", " : "", f);
        }
        fprintf(f, "]%s\n", l + 1 < r->nlimbs ? "," : "");
    }
    fputs("  ]\n}\n", f);
    int werr = ferror(f);
    if (fclose(f) != 0 || werr)
        return mdl__err(err, -EIO, "%s: write failed", path);
    if (e)
        return mdl__err(err, -ENOMEM, "%s: out of memory", path);
    return 0;
}
