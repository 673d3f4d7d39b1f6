/* corr.c - the correspondences file of the harmonic kind: which target triangles a user ties to
 * each template bone (de Aguiar et al. 2007 Sec. 4.2; docs/FORMATS.md "Correspondences file").
 *
 *   { "correspondences": [ {"bone": ["LeftHip", "LeftKnee"], "triangles": [5012]}, ... ] }
 *
 * A bone is named by the [from, to] marker names of one of the rig's limbs; its triangles are
 * 0-based indices into the target's faces. On a cylindrical part one triangle is enough: the build
 * adds its cross-section (correspondences.c). Bones the file does not name get the automatic
 * proposal. JSON syntax comes from cJSON; every message names the file and the JSON path. */
#include "model.h"
#include "core/util.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <stdlib.h>
#include <math.h>
#include <string.h>

#define CORR_MAX_FILE ((size_t)16 << 20)

/* the rig limb whose first two markers are named a, b; -1 if none */
static int find_bone(const mdl_rig *rig, const char *a, const char *b)
{
    for (int l = 0; l < rig->nlimbs; l++) {
        const char *fa = rig->markers[rig->limb_idx[rig->limb_off[l]]].name;
        const char *fb = rig->markers[rig->limb_idx[rig->limb_off[l] + 1]].name;
        if (strcmp(fa, a) == 0 && strcmp(fb, b) == 0)
            return l;
    }
    return -1;
}

static int parse_entries(const cJSON *list, const char *name, const mdl_rig *rig, int nf, int *cnt,
                         int *bone_of, int pass, int *off, int *idx, char *err)
{
    int i = 0;
    const cJSON *e;
    cJSON_ArrayForEach(e, list) {
        const cJSON *bone = cJSON_GetObjectItemCaseSensitive(e, "bone");
        const cJSON *tris = cJSON_GetObjectItemCaseSensitive(e, "triangles");
        if (!cJSON_IsObject(e))
            return mdl__err(err, MDL_EFORMAT, "%s: correspondences[%d]: must be an object", name, i);
        if (!cJSON_IsArray(bone) || cJSON_GetArraySize(bone) != 2 ||
            !cJSON_IsString(cJSON_GetArrayItem(bone, 0)) || !cJSON_IsString(cJSON_GetArrayItem(bone, 1)))
            return mdl__err(err, MDL_EFORMAT, "%s: correspondences[%d].bone: must be [from, to], two "
                            "marker names", name, i);
        const char *a = cJSON_GetArrayItem(bone, 0)->valuestring, *b = cJSON_GetArrayItem(bone, 1)->valuestring;
        int l = find_bone(rig, a, b);
        if (l < 0)
            return mdl__err(err, MDL_EFORMAT, "%s: correspondences[%d].bone: [\"%.40s\", \"%.40s\"] is "
                            "no limb of the rig", name, i, a, b);
        if (pass == 0 && bone_of[l] >= 0)
            return mdl__err(err, MDL_EFORMAT, "%s: correspondences[%d].bone: [\"%.40s\", \"%.40s\"] "
                            "already given at correspondences[%d]", name, i, a, b, bone_of[l]);
        bone_of[l] = i;
        int n = cJSON_IsArray(tris) ? cJSON_GetArraySize(tris) : 0;
        if (n < 1)
            return mdl__err(err, MDL_EFORMAT, "%s: correspondences[%d].triangles: must be a non-empty "
                            "array of triangle indices", name, i);
        for (int k = 0; k < n; k++) {
            const cJSON *t = cJSON_GetArrayItem(tris, k);
            /* range first: casting a double outside int's range is undefined (found by fuzz_corr) */
            if (!cJSON_IsNumber(t) || !(t->valuedouble >= 0 && t->valuedouble < nf) ||
                t->valuedouble != floor(t->valuedouble))
                return mdl__err(err, MDL_EFORMAT, "%s: correspondences[%d].triangles[%d]: must be a "
                                "triangle index within 0..%d", name, i, k, nf - 1);
            if (pass == 1)
                idx[off[l] + cnt[l]] = (int)t->valuedouble;
            cnt[l]++;
        }
        i++;
    }
    return 0;
}

int mdl_corr_parse(const char *buf, size_t len, const char *name, const mdl_rig *rig, int nf,
                   int **off_out, int **idx_out, char *err)
{
    *off_out = *idx_out = NULL;
    if (!name)
        name = "<correspondences>";
    if (!rig || rig->nlimbs < 1 || nf < 1)
        return mdl__err(err, -EINVAL, "%s: correspondences need a rig with limbs and a target mesh", name);
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(buf, len, &end, 0);
    if (!root)
        return mdl__err(err, MDL_EFORMAT, "%s: offset %zu: invalid JSON", name,
                        end && end >= buf && end <= buf + len ? (size_t)(end - buf) : (size_t)0);
    int nb = rig->nlimbs, e = 0;
    int *off = mdl__calloc((size_t)nb + 1, sizeof *off), *cnt = mdl__calloc((size_t)nb, sizeof *cnt);
    int *bone_of = mdl__calloc((size_t)nb, sizeof *bone_of), *idx = NULL;
    const cJSON *list = cJSON_IsObject(root) ? cJSON_GetObjectItemCaseSensitive(root, "correspondences") : NULL;
    if (!off || !cnt || !bone_of)
        e = mdl__err(err, -ENOMEM, "%s: out of memory", name);
    else if (!cJSON_IsObject(root))
        e = mdl__err(err, MDL_EFORMAT, "%s: the top level must be a JSON object", name);
    else if (!cJSON_IsArray(list) || cJSON_GetArraySize(list) < 1)
        e = mdl__err(err, MDL_EFORMAT, "%s: correspondences: must be a non-empty array", name);
    for (int l = 0; !e && l < nb; l++)
        bone_of[l] = -1;
    /* pass 0 counts per bone, pass 1 fills */
    if (!e)
        e = parse_entries(list, name, rig, nf, cnt, bone_of, 0, off, NULL, err);
    if (!e) {
        for (int l = 0; l < nb; l++)
            off[l + 1] = off[l] + cnt[l];
        idx = mdl__calloc((size_t)off[nb] + 1, sizeof *idx);
        memset(cnt, 0, (size_t)nb * sizeof *cnt);
        e = idx ? parse_entries(list, name, rig, nf, cnt, bone_of, 1, off, idx, err)
                : mdl__err(err, -ENOMEM, "%s: out of memory", name);
    }
    cJSON_Delete(root);
    free(cnt);
    free(bone_of);
    if (e) {
        free(off);
        free(idx);
        return e;
    }
    *off_out = off;
    *idx_out = idx;
    return 0;
}

int mdl_corr_read(const char *path, const mdl_rig *rig, int nf, int **off, int **idx, char *err)
{
    *off = *idx = NULL;
    char *buf;
    size_t len;
    int r = mdl__read_file(path, CORR_MAX_FILE, &buf, &len, err);
    if (r)
        return r;
    r = mdl_corr_parse(buf, len, path, rig, nf, off, idx, err);
    free(buf);
    return r;
}
