/* gltf.c - a skin as a glTF 2.0 binary (.glb) [Khronos glTF 2.0 specification, Sec. 3.7.3
 * (skins: joints, inverseBindMatrices, JOINTS_0/WEIGHTS_0), 3.11 (animations), 4.4 (GLB)],
 * written with cJSON and one binary buffer (no Debian glTF writer library fits better: cgltf is
 * not packaged with a writer we could link, and the format is small).
 *
 * Conventions, so that three.js, assimp and Blender's importer read it as we mean it:
 *   - metres, right-handed, +Y up, as the model (DESIGN.md "Data and units"; glTF's own frame);
 *   - one mesh node (the rest pose, triangles) with skin 0; one joint node per bone, named
 *     "bone_000", ..., children of a root node "Armature" (identity), each placed at rest at its
 *     bone's centroid c_j (the weighted mean of the rest vertices it moves), so the bones sit in
 *     the body in Blender instead of at the origin; inverseBindMatrices = translate(-c_j);
 *   - one animation per clip (mdl_skin_write_gltf: one, "ssdr", the fitted frames; `meshsteer
 *     variations --gltf`: one per variation), each with per bone a translation and a rotation
 *     channel and a sample per frame at f / fps (LINEAR): the joint's transform is T_j^f translate(c_j), i.e.
 *     rotation R_j^f and translation R_j^f c_j + t_j^f, so the skinned vertex is
 *     sum_j w_ij T_j^f p_i exactly as the skin (Le & Deng's LBS model, ssdr.h); with close_loop,
 *     one more key at N / fps repeats frame 0, so the clip lasts N / fps and an engine looping it
 *     (three.js's default LoopRepeat, Blender's cyclic NLA) goes from frame N - 1 to frame 0 in one
 *     frame's time, as the skin's own playback (play.c) does; without it the clip ends at
 *     (N - 1) / fps (a clip played once);
 *   - quaternions (x, y, z, w), sign-continuous from frame to frame; weights float, normalised
 *     to a unit sum; joints unsigned short. Needs K <= 4 (one JOINTS_0/WEIGHTS_0 set).
 * Read back by three.js's GLTFLoader in headless chromium (tests/model/skin/gltf_three.mjs, meson
 * test gltf_three): its skinned vertices at frames 0, N/2, N-1 match the skin's own. */
#include "model.h"
#include "core/rigid.h"
#include "core/util.h"

#include <cjson/cJSON.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct bin {
    uint8_t *p;
    size_t n, cap;
} bin;

/* Appends n bytes (padded to 4); the offset, or -1 out of memory. */
static long put(bin *b, const void *src, size_t n)
{
    size_t need = b->n + ((n + 3) & ~(size_t)3);
    if (need > b->cap) {
        size_t cap = b->cap ? b->cap : 1u << 16;
        while (cap < need)
            cap *= 2;
        uint8_t *q = realloc(b->p, cap);
        if (!q)
            return -1;
        memset(q + b->cap, 0, cap - b->cap);
        b->p = q;
        b->cap = cap;
    }
    size_t at = b->n;
    memcpy(b->p + at, src, n);
    b->n = need;
    return (long)at;
}

static void view_accessor(cJSON *views, cJSON *accs, size_t off, size_t len, int ctype, int count,
                          const char *type, const float *mn, const float *mx, int ncomp)
{
    cJSON *v = cJSON_CreateObject();
    cJSON_AddNumberToObject(v, "buffer", 0);
    cJSON_AddNumberToObject(v, "byteOffset", (double)off);
    cJSON_AddNumberToObject(v, "byteLength", (double)len);
    int vi = cJSON_GetArraySize(views);
    cJSON_AddItemToArray(views, v);
    cJSON *a = cJSON_CreateObject();
    cJSON_AddNumberToObject(a, "bufferView", vi);
    cJSON_AddNumberToObject(a, "componentType", ctype);
    cJSON_AddNumberToObject(a, "count", count);
    cJSON_AddStringToObject(a, "type", type);
    if (mn && mx) {
        cJSON *jmn = cJSON_AddArrayToObject(a, "min"), *jmx = cJSON_AddArrayToObject(a, "max");
        for (int c = 0; c < ncomp; c++) {
            cJSON_AddItemToArray(jmn, cJSON_CreateNumber(mn[c]));
            cJSON_AddItemToArray(jmx, cJSON_CreateNumber(mx[c]));
        }
    }
    cJSON_AddItemToArray(accs, a);
}

struct mdl_gltf {
    int nb, nv;
    bin b;
    double *cen;  /* nb x 4: each bone's rest centroid (x, y, z, weight sum) */
    float *tmp;
    size_t ntmp;  /* floats in tmp */
    cJSON *root, *views, *accs, *anims;
};

/* A blob into the buffer and its accessor; 0, or -1 out of memory. */
static int blob(mdl_gltf *g, const void *src, size_t len, int ctype, int count, const char *type,
                const float *mn, const float *mx, int ncomp)
{
    long o = put(&g->b, src, len);
    if (o < 0)
        return -1;
    view_accessor(g->views, g->accs, (size_t)o, len, ctype, count, type, mn, mx, ncomp);
    return 0;
}

void mdl_gltf_free(mdl_gltf *g)
{
    if (!g)
        return;
    cJSON_Delete(g->root);
    free(g->b.p);
    free(g->cen);
    free(g->tmp);
    free(g);
}

int mdl_gltf_begin(const mdl_model *m, mdl_gltf **out, char *err)
{
    *out = NULL;
    int nb, K, nfr;
    const int *bone;
    const double *w, *T;
    if (mdl_skin_get(m, &nb, &K, &nfr, &bone, &w, &T))
        return mdl__err(err, -ENOENT, "the model holds no skin");
    if (K > 4)
        return mdl__err(err, -EINVAL, "%d influences per vertex; glTF JOINTS_0 holds 4", K);
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    int nv = info.nv, nf = info.nf;
    mdl_gltf *g = mdl__calloc(1, sizeof *g);
    uint16_t *jt = mdl__calloc(4 * (size_t)nv, sizeof *jt);
    float *wt = mdl__calloc(4 * (size_t)nv, sizeof *wt);
    float *ibm = mdl__calloc(16 * (size_t)nb, sizeof *ibm);
    int rc = 0;
    if (!g || !jt || !wt || !ibm || !(g->cen = mdl__calloc(4 * (size_t)nb, sizeof *g->cen)) ||
        !(g->root = cJSON_CreateObject())) {
        rc = mdl__err(err, -ENOMEM, "out of memory");
        goto out;
    }
    g->nb = nb;
    g->nv = nv;
    double *cen = g->cen;
    /* bone centroids at rest, weights and joints */
    for (int i = 0; i < nv; i++) {
        float s = 0;
        for (int q = 0; q < 4; q++) {
            double x = q < K ? w[(size_t)K * i + q] : 0;
            int j = q < K ? bone[(size_t)K * i + q] : 0;
            jt[4 * i + q] = (uint16_t)(x > 0 ? j : 0);
            wt[4 * i + q] = (float)x;
            s += wt[4 * i + q];
            if (x > 0) {
                for (int c = 0; c < 3; c++)
                    cen[4 * j + c] += x * info.rest[3 * i + c];
                cen[4 * j + 3] += x;
            }
        }
        for (int q = 0; q < 4; q++)
            wt[4 * i + q] /= s;
    }
    for (int j = 0; j < nb; j++)
        for (int c = 0; c < 3; c++)
            cen[4 * j + c] = cen[4 * j + 3] > 0 ? cen[4 * j + c] / cen[4 * j + 3] : 0;

    cJSON *root = g->root;
    cJSON *asset = cJSON_AddObjectToObject(root, "asset");
    cJSON_AddStringToObject(asset, "version", "2.0");
    cJSON_AddStringToObject(asset, "generator", "meshsteer skin (SSDR, Le & Deng 2012)");
    g->views = cJSON_AddArrayToObject(root, "bufferViews");
    g->accs = cJSON_AddArrayToObject(root, "accessors");

    float mn[3] = {INFINITY, INFINITY, INFINITY}, mx[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < nv; i++)
        for (int c = 0; c < 3; c++) {
            mn[c] = fminf(mn[c], info.rest[3 * i + c]);
            mx[c] = fmaxf(mx[c], info.rest[3 * i + c]);
        }
    for (int j = 0; j < nb; j++) {
        float *M = ibm + 16 * (size_t)j; /* column-major 4x4 */
        M[0] = M[5] = M[10] = M[15] = 1;
        for (int c = 0; c < 3; c++)
            M[12 + c] = (float)-cen[4 * j + c];
    }
    if (blob(g, info.rest, 12 * (size_t)nv, 5126, nv, "VEC3", mn, mx, 3) ||          /* 0 POSITION */
        blob(g, info.F, 12 * (size_t)nf, 5125, 3 * nf, "SCALAR", NULL, NULL, 0) ||   /* 1 indices */
        blob(g, jt, 8 * (size_t)nv, 5123, nv, "VEC4", NULL, NULL, 0) ||              /* 2 JOINTS_0 */
        blob(g, wt, 16 * (size_t)nv, 5126, nv, "VEC4", NULL, NULL, 0) ||             /* 3 WEIGHTS_0 */
        blob(g, ibm, 64 * (size_t)nb, 5126, nb, "MAT4", NULL, NULL, 0)) {            /* 4 IBM */
        rc = mdl__err(err, -ENOMEM, "out of memory");
        goto out;
    }

    cJSON *meshes = cJSON_AddArrayToObject(root, "meshes"), *mesh = cJSON_CreateObject();
    cJSON_AddStringToObject(mesh, "name", info.name);
    cJSON *prims = cJSON_AddArrayToObject(mesh, "primitives"), *prim = cJSON_CreateObject();
    cJSON *attr = cJSON_AddObjectToObject(prim, "attributes");
    cJSON_AddNumberToObject(attr, "POSITION", 0);
    cJSON_AddNumberToObject(attr, "JOINTS_0", 2);
    cJSON_AddNumberToObject(attr, "WEIGHTS_0", 3);
    cJSON_AddNumberToObject(prim, "indices", 1);
    cJSON_AddNumberToObject(prim, "mode", 4);
    cJSON_AddItemToArray(prims, prim);
    cJSON_AddItemToArray(meshes, mesh);

    /* nodes: 0 the mesh, 1 .. nb the joints, nb + 1 the Armature */
    cJSON *nodes = cJSON_AddArrayToObject(root, "nodes"), *nm = cJSON_CreateObject();
    cJSON_AddStringToObject(nm, "name", info.name[0] ? info.name : "skin");
    cJSON_AddNumberToObject(nm, "mesh", 0);
    cJSON_AddNumberToObject(nm, "skin", 0);
    cJSON_AddItemToArray(nodes, nm);
    cJSON *skin = cJSON_CreateObject(), *joints = cJSON_AddArrayToObject(skin, "joints");
    for (int j = 0; j < nb; j++) {
        char name[32];
        snprintf(name, sizeof name, "bone_%03d", j);
        cJSON *n = cJSON_CreateObject(), *t = cJSON_AddArrayToObject(n, "translation");
        cJSON_AddStringToObject(n, "name", name);
        for (int c = 0; c < 3; c++)
            cJSON_AddItemToArray(t, cJSON_CreateNumber((float)cen[4 * j + c]));
        cJSON_AddItemToArray(nodes, n);
        cJSON_AddItemToArray(joints, cJSON_CreateNumber(1 + j));
    }
    cJSON *arm = cJSON_CreateObject(), *ch = cJSON_AddArrayToObject(arm, "children");
    cJSON_AddStringToObject(arm, "name", "Armature");
    for (int j = 0; j < nb; j++)
        cJSON_AddItemToArray(ch, cJSON_CreateNumber(1 + j));
    cJSON_AddItemToArray(nodes, arm);
    cJSON_AddNumberToObject(skin, "inverseBindMatrices", 4);
    cJSON_AddNumberToObject(skin, "skeleton", nb + 1);
    cJSON_AddStringToObject(skin, "name", "ssdr");
    cJSON *skins = cJSON_AddArrayToObject(root, "skins");
    cJSON_AddItemToArray(skins, skin);
    cJSON *scenes = cJSON_AddArrayToObject(root, "scenes"), *sc = cJSON_CreateObject();
    cJSON *sn = cJSON_AddArrayToObject(sc, "nodes");
    cJSON_AddItemToArray(sn, cJSON_CreateNumber(0));
    cJSON_AddItemToArray(sn, cJSON_CreateNumber(nb + 1));
    cJSON_AddItemToArray(scenes, sc);
    cJSON_AddNumberToObject(root, "scene", 0);
    g->anims = cJSON_AddArrayToObject(root, "animations");
out:
    free(jt);
    free(wt);
    free(ibm);
    if (rc) {
        mdl_gltf_free(g);
        return rc;
    }
    *out = g;
    return 0;
}

int mdl_gltf_add_clip(mdl_gltf *g, const char *name, const double *T, int frames, double fps,
                      int close_loop, char *err)
{
    if (frames < 1 || !(fps > 0))
        return mdl__err(err, -EINVAL, "clip '%s': %d frames at %g fps", name, frames, fps);
    int nb = g->nb, nk = frames + (close_loop ? 1 : 0); /* keys: the frames, then frame 0 again */
    size_t need = 7 * (size_t)nk;
    if (need > g->ntmp) {
        float *t = realloc(g->tmp, need * sizeof *t);
        if (!t)
            return mdl__err(err, -ENOMEM, "out of memory");
        g->tmp = t;
        g->ntmp = need;
    }
    int base = cJSON_GetArraySize(g->accs); /* times, then per bone translations, rotations */
    float *times = g->tmp;
    for (int f = 0; f < nk; f++)
        times[f] = (float)(f / fps);
    float tmn = 0, tmx = times[nk - 1];
    if (blob(g, times, 4 * (size_t)nk, 5126, nk, "SCALAR", &tmn, &tmx, 1))
        return mdl__err(err, -ENOMEM, "out of memory");
    for (int j = 0; j < nb; j++) {
        float *tr = g->tmp, *rot = g->tmp + 3 * (size_t)nk;
        double prev[4] = {1, 0, 0, 0};
        for (int f = 0; f < nk; f++) {
            const double *M = T + 12 * ((size_t)(f % frames) * nb + j), *c = g->cen + 4 * (size_t)j;
            double q[4];
            mdl__mat_to_quat(M, q);
            double dot = q[0] * prev[0] + q[1] * prev[1] + q[2] * prev[2] + q[3] * prev[3];
            if (dot < 0)
                for (int k = 0; k < 4; k++)
                    q[k] = -q[k];
            double qn = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
            memcpy(prev, q, sizeof prev);
            rot[4 * f + 0] = (float)(q[1] / qn);
            rot[4 * f + 1] = (float)(q[2] / qn);
            rot[4 * f + 2] = (float)(q[3] / qn);
            rot[4 * f + 3] = (float)(q[0] / qn);
            for (int a = 0; a < 3; a++)
                tr[3 * f + a] = (float)(M[3 * a] * c[0] + M[3 * a + 1] * c[1] + M[3 * a + 2] * c[2] + M[9 + a]);
        }
        if (blob(g, tr, 12 * (size_t)nk, 5126, nk, "VEC3", NULL, NULL, 0) ||
            blob(g, rot, 16 * (size_t)nk, 5126, nk, "VEC4", NULL, NULL, 0))
            return mdl__err(err, -ENOMEM, "out of memory");
    }
    cJSON *an = cJSON_CreateObject();
    cJSON_AddStringToObject(an, "name", name);
    cJSON *chans = cJSON_AddArrayToObject(an, "channels"), *samps = cJSON_AddArrayToObject(an, "samplers");
    for (int j = 0; j < nb; j++)
        for (int k = 0; k < 2; k++) {
            cJSON *s = cJSON_CreateObject();
            cJSON_AddNumberToObject(s, "input", base);
            cJSON_AddNumberToObject(s, "output", base + 1 + 2 * j + k);
            cJSON_AddStringToObject(s, "interpolation", "LINEAR");
            cJSON_AddItemToArray(samps, s);
            cJSON *c = cJSON_CreateObject(), *tg = cJSON_AddObjectToObject(c, "target");
            cJSON_AddNumberToObject(c, "sampler", 2 * j + k);
            cJSON_AddNumberToObject(tg, "node", 1 + j);
            cJSON_AddStringToObject(tg, "path", k ? "rotation" : "translation");
            cJSON_AddItemToArray(chans, c);
        }
    cJSON_AddItemToArray(g->anims, an);
    return 0;
}

int mdl_gltf_write(mdl_gltf *g, const char *path, char *err)
{
    cJSON *buffers = cJSON_AddArrayToObject(g->root, "buffers"), *buf = cJSON_CreateObject();
    cJSON_AddNumberToObject(buf, "byteLength", (double)g->b.n);
    cJSON_AddItemToArray(buffers, buf);
    char *js = cJSON_PrintUnformatted(g->root);
    cJSON_DeleteItemFromObject(g->root, "buffers"); /* the writer stays usable */
    if (!js)
        return mdl__err(err, -ENOMEM, "%s: out of memory", path);
    size_t jl = strlen(js), jp = (jl + 3) & ~(size_t)3, bp = (g->b.n + 3) & ~(size_t)3;
    if (12 + 8 + jp + 8 + bp > UINT32_MAX) {
        free(js);
        return mdl__err(err, -EFBIG, "%s: %zu bytes, more than a GLB holds (4 GiB)", path,
                        12 + 8 + jp + 8 + bp);
    }
    uint32_t hdr[3] = {0x46546C67u, 2, (uint32_t)(12 + 8 + jp + 8 + bp)};
    uint32_t jh[2] = {(uint32_t)jp, 0x4E4F534Au}, bh[2] = {(uint32_t)bp, 0x004E4942u};
    FILE *fp = fopen(path, "wb");
    if (!fp) {
        int e = errno;
        free(js);
        return mdl__err(err, -e, "%s: %s", path, strerror(e));
    }
    static const char pad[4] = {' ', ' ', ' ', ' '}, zero[4] = {0, 0, 0, 0};
    int ok = fwrite(hdr, 4, 3, fp) == 3 && fwrite(jh, 4, 2, fp) == 2 && fwrite(js, 1, jl, fp) == jl &&
             fwrite(pad, 1, jp - jl, fp) == jp - jl && fwrite(bh, 4, 2, fp) == 2 &&
             fwrite(g->b.p, 1, g->b.n, fp) == g->b.n && fwrite(zero, 1, bp - g->b.n, fp) == bp - g->b.n;
    free(js);
    if (fclose(fp) != 0 || !ok)
        return mdl__err(err, -EIO, "%s: write failed", path);
    return 0;
}

int mdl_skin_write_gltf(const mdl_model *m, const char *path, int close_loop, char *err)
{
    int nb, K, nfr;
    const int *bone;
    const double *w, *T;
    if (mdl_skin_get(m, &nb, &K, &nfr, &bone, &w, &T))
        return mdl__err(err, -ENOENT, "%s: the model holds no skin", path);
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    mdl_gltf *g;
    char e[MDL_ERR_LEN];
    int rc = mdl_gltf_begin(m, &g, e);
    if (rc)
        return mdl__err(err, rc, "%s: %s", path, e);
    rc = mdl_gltf_add_clip(g, "ssdr", T, nfr, info.fps > 0 ? info.fps : 30, close_loop, e);
    if (rc)
        rc = mdl__err(err, rc, "%s: %s", path, e);
    else
        rc = mdl_gltf_write(g, path, err);
    mdl_gltf_free(g);
    return rc;
}
