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
 *   - one animation "ssdr": per bone a translation and a rotation channel with a sample per
 *     fitted frame at f / fps (LINEAR): the joint's transform is T_j^f translate(c_j), i.e.
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
    size_t n;
} bin;

static size_t put(bin *b, const void *src, size_t n)
{
    size_t at = b->n;
    memcpy(b->p + at, src, n);
    b->n += (n + 3) & ~(size_t)3;
    return at;
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

int mdl_skin_write_gltf(const mdl_model *m, const char *path, int close_loop, char *err)
{
    int nb, K, nfr;
    const int *bone;
    const double *w, *T;
    if (mdl_skin_get(m, &nb, &K, &nfr, &bone, &w, &T))
        return mdl__err(err, -ENOENT, "%s: the model holds no skin", path);
    if (K > 4)
        return mdl__err(err, -EINVAL, "%s: %d influences per vertex; glTF JOINTS_0 holds 4", path, K);
    mdl_model_info info;
    mdl_model_get_info(m, &info);
    int nv = info.nv, nf = info.nf;
    double fps = info.fps > 0 ? info.fps : 30;
    int nk = nfr + (close_loop ? 1 : 0); /* keys: the fitted frames, then frame 0 again */
    size_t cap = (size_t)nv * (12 + 8 + 16) + (size_t)nf * 12 + (size_t)nb * 64 + (size_t)nk * 4 +
                 (size_t)nk * nb * 28 + 8 * (size_t)nb + 64;
    bin b = {mdl__calloc(cap, 1), 0};
    double *cen = mdl__calloc(4 * (size_t)nb, sizeof *cen);
    uint16_t *jt = mdl__calloc(4 * (size_t)nv, sizeof *jt);
    float *wt = mdl__calloc(4 * (size_t)nv, sizeof *wt), *tmp = mdl__calloc(7 * (size_t)nk + 16 * (size_t)nb, sizeof *tmp);
    cJSON *root = cJSON_CreateObject();
    int rc = 0;
    if (!b.p || !cen || !jt || !wt || !tmp || !root) {
        rc = mdl__err(err, -ENOMEM, "%s: out of memory", path);
        goto out;
    }
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

    cJSON *asset = cJSON_AddObjectToObject(root, "asset");
    cJSON_AddStringToObject(asset, "version", "2.0");
    cJSON_AddStringToObject(asset, "generator", "meshsteer skin (SSDR, Le & Deng 2012)");
    cJSON *views = cJSON_AddArrayToObject(root, "bufferViews");
    cJSON *accs = cJSON_AddArrayToObject(root, "accessors");

    float mn[3] = {INFINITY, INFINITY, INFINITY}, mx[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < nv; i++)
        for (int c = 0; c < 3; c++) {
            mn[c] = fminf(mn[c], info.rest[3 * i + c]);
            mx[c] = fmaxf(mx[c], info.rest[3 * i + c]);
        }
    size_t o = put(&b, info.rest, 12 * (size_t)nv);
    view_accessor(views, accs, o, 12 * (size_t)nv, 5126, nv, "VEC3", mn, mx, 3); /* 0 POSITION */
    o = put(&b, info.F, 12 * (size_t)nf);
    view_accessor(views, accs, o, 12 * (size_t)nf, 5125, 3 * nf, "SCALAR", NULL, NULL, 0); /* 1 */
    o = put(&b, jt, 8 * (size_t)nv);
    view_accessor(views, accs, o, 8 * (size_t)nv, 5123, nv, "VEC4", NULL, NULL, 0); /* 2 JOINTS_0 */
    o = put(&b, wt, 16 * (size_t)nv);
    view_accessor(views, accs, o, 16 * (size_t)nv, 5126, nv, "VEC4", NULL, NULL, 0); /* 3 WEIGHTS_0 */
    float *ibm = tmp;
    for (int j = 0; j < nb; j++) {
        float *M = ibm + 16 * (size_t)j; /* column-major 4x4 */
        memset(M, 0, 16 * sizeof *M);
        M[0] = M[5] = M[10] = M[15] = 1;
        for (int c = 0; c < 3; c++)
            M[12 + c] = (float)-cen[4 * j + c];
    }
    o = put(&b, ibm, 64 * (size_t)nb);
    view_accessor(views, accs, o, 64 * (size_t)nb, 5126, nb, "MAT4", NULL, NULL, 0); /* 4 IBM */
    float *times = tmp;
    for (int f = 0; f < nk; f++)
        times[f] = (float)(f / fps);
    float tmn = 0, tmx = times[nk - 1];
    o = put(&b, times, 4 * (size_t)nk);
    view_accessor(views, accs, o, 4 * (size_t)nk, 5126, nk, "SCALAR", &tmn, &tmx, 1); /* 5 */
    /* per bone: translations (accessor 6 + 2j), rotations (7 + 2j) */
    for (int j = 0; j < nb; j++) {
        float *tr = tmp, *rot = tmp + 3 * (size_t)nk;
        double prev[4] = {1, 0, 0, 0};
        for (int f = 0; f < nk; f++) {
            const double *M = T + 12 * ((size_t)(f % nfr) * nb + j), *c = cen + 4 * (size_t)j;
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
        o = put(&b, tr, 12 * (size_t)nk);
        view_accessor(views, accs, o, 12 * (size_t)nk, 5126, nk, "VEC3", NULL, NULL, 0);
        o = put(&b, rot, 16 * (size_t)nk);
        view_accessor(views, accs, o, 16 * (size_t)nk, 5126, nk, "VEC4", NULL, NULL, 0);
    }
    cJSON *buffers = cJSON_AddArrayToObject(root, "buffers"), *buf = cJSON_CreateObject();
    cJSON_AddNumberToObject(buf, "byteLength", (double)b.n);
    cJSON_AddItemToArray(buffers, buf);

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

    cJSON *anims = cJSON_AddArrayToObject(root, "animations"), *an = cJSON_CreateObject();
    cJSON_AddStringToObject(an, "name", "ssdr");
    cJSON *chans = cJSON_AddArrayToObject(an, "channels"), *samps = cJSON_AddArrayToObject(an, "samplers");
    for (int j = 0; j < nb; j++)
        for (int k = 0; k < 2; k++) {
            cJSON *s = cJSON_CreateObject();
            cJSON_AddNumberToObject(s, "input", 5);
            cJSON_AddNumberToObject(s, "output", 6 + 2 * j + k);
            cJSON_AddStringToObject(s, "interpolation", "LINEAR");
            cJSON_AddItemToArray(samps, s);
            cJSON *c = cJSON_CreateObject(), *tg = cJSON_AddObjectToObject(c, "target");
            cJSON_AddNumberToObject(c, "sampler", 2 * j + k);
            cJSON_AddNumberToObject(tg, "node", 1 + j);
            cJSON_AddStringToObject(tg, "path", k ? "rotation" : "translation");
            cJSON_AddItemToArray(chans, c);
        }
    cJSON_AddItemToArray(anims, an);

    char *js = cJSON_PrintUnformatted(root);
    if (!js) {
        rc = mdl__err(err, -ENOMEM, "%s: out of memory", path);
        goto out;
    }
    size_t jl = strlen(js), jp = (jl + 3) & ~(size_t)3, bp = (b.n + 3) & ~(size_t)3;
    uint32_t hdr[3] = {0x46546C67u, 2, (uint32_t)(12 + 8 + jp + 8 + bp)};
    uint32_t jh[2] = {(uint32_t)jp, 0x4E4F534Au}, bh[2] = {(uint32_t)bp, 0x004E4942u};
    FILE *fp = fopen(path, "wb");
    if (!fp) {
        free(js);
        rc = mdl__err(err, -errno, "%s: %s", path, strerror(errno));
        goto out;
    }
    static const char pad[4] = {' ', ' ', ' ', ' '}, zero[4] = {0, 0, 0, 0};
    int ok = fwrite(hdr, 4, 3, fp) == 3 && fwrite(jh, 4, 2, fp) == 2 && fwrite(js, 1, jl, fp) == jl &&
             fwrite(pad, 1, jp - jl, fp) == jp - jl && fwrite(bh, 4, 2, fp) == 2 &&
             fwrite(b.p, 1, b.n, fp) == b.n && fwrite(zero, 1, bp - b.n, fp) == bp - b.n;
    free(js);
    if (fclose(fp) != 0 || !ok)
        rc = mdl__err(err, -EIO, "%s: write failed", path);
out:
    cJSON_Delete(root);
    free(b.p);
    free(cen);
    free(jt);
    free(wt);
    free(tmp);
    return rc;
}
