/* bvh.c - Biovision hierarchy (BVH) files read as markers by forward kinematics.
 *
 * Format (Biovision; see Meredith & Maddock 2001, "Motion Capture File Formats Explained"):
 *   HIERARCHY
 *   ROOT name { OFFSET x y z  CHANNELS n c1 .. cn  JOINT name { ... }  End Site { OFFSET x y z } }
 *   MOTION
 *   Frames: F
 *   Frame Time: dt
 *   F rows of the channel values in declaration order (rows may wrap; only the count matters).
 * Channels are Xposition Yposition Zposition Xrotation Yrotation Zrotation (degrees), on any joint
 * and in any order. Several ROOTs are allowed. Line endings may be LF, CRLF or mixed.
 *
 * Forward kinematics, per frame, for joint j with parent p (world rotation R_p, position x_p):
 *   t_j = OFFSET_j, each component replaced by its position channel when the joint has one
 *         (position channels are the joint's translation in the parent frame, as Blender reads
 *         them: for the usual root with OFFSET 0 0 0 this equals OFFSET + channel);
 *   R_j = R_p * R_c1 * R_c2 * ...   (rotation channels in the order they are listed);
 *   x_j = x_p + R_p * t_j            (roots: R_p = I, x_p = 0).
 * With opts->rest the result is one frame: the rest pose (every channel zero; the root at its
 * OFFSET). Every joint AND every End Site becomes a marker, in declaration order. An End Site is named
 * "<parent>_End" (a repeated name gets "#2"). All samples are valid.
 * Joint rotations (mdl_markers.rot, parent): marker j's segment from its parent p is R_p t_j, so
 * rot[j] = R_p (R_j for a root), parent[j] = p; every R is the identity in the rest pose.
 *
 * Units: opts->scale when given. Otherwise the scale is guessed from the skeleton's height in the
 * first frame (extent along the up axis over all markers): among metre (1), centimetre (0.01),
 * millimetre (0.001), inch (0.0254) and the CMU unit of 1/0.45 inch (0.056444 m), the unit whose
 * resulting height is closest to 1.75 m (metre when there is no frame or no height). Default up
 * axis +Y. */
#include "formats/markers_internal.h"
#include "model.h"
#include "core/rigid.h"
#include "core/util.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define BVH_MAX_DEPTH 256

enum { CH_XPOS, CH_YPOS, CH_ZPOS, CH_XROT, CH_YROT, CH_ZROT };

typedef struct bvh_node {
    char *name;
    int parent;     /* -1 for a root */
    int is_end;
    double offset[3];
    int nch, ch0;   /* channels ch[ch0 .. ch0 + nch) */
} bvh_node;

typedef struct bvh {
    char *s;        /* NUL-terminated copy of the file */
    size_t pos, len;
    int line;
    const char *name;
    bvh_node *nodes;
    int nnodes, cnodes;
    int *ch;        /* channel kinds */
    int nch, cch;
    char tok[128];
    int tok_line;
} bvh;

/* Next whitespace-separated token into p->tok (truncated at 127 bytes); 0 at the end. */
static int next_tok(bvh *p)
{
    while (p->pos < p->len && isspace((unsigned char)p->s[p->pos])) {
        if (p->s[p->pos] == '\n')
            p->line++;
        p->pos++;
    }
    if (p->pos >= p->len)
        return 0;
    size_t n = 0;
    p->tok_line = p->line;
    while (p->pos < p->len && !isspace((unsigned char)p->s[p->pos])) {
        if (n + 1 < sizeof p->tok)
            p->tok[n++] = p->s[p->pos];
        p->pos++;
    }
    p->tok[n] = 0;
    return 1;
}

static int tok_num(bvh *p, double *v, const char *what, char *err)
{
    if (!next_tok(p))
        return mdl__err(err, MDL_EFORMAT, "%s:%d: file ends where %s was expected", p->name,
                        p->line, what);
    char *end;
    *v = strtod(p->tok, &end);
    if (end == p->tok || *end || !isfinite(*v))
        return mdl__err(err, MDL_EFORMAT, "%s:%d: '%s' is not a number (%s)", p->name,
                        p->tok_line, p->tok, what);
    return 0;
}

static int expect(bvh *p, const char *word, char *err)
{
    if (!next_tok(p))
        return mdl__err(err, MDL_EFORMAT, "%s:%d: file ends where '%s' was expected", p->name,
                        p->line, word);
    if (strcasecmp(p->tok, word) != 0)
        return mdl__err(err, MDL_EFORMAT, "%s:%d: '%s' where '%s' was expected", p->name,
                        p->tok_line, p->tok, word);
    return 0;
}

static int add_node(bvh *p, const char *name, size_t nlen, int parent, int is_end)
{
    if (p->nnodes == p->cnodes) {
        int nc = p->cnodes ? 2 * p->cnodes : 64;
        bvh_node *n = realloc(p->nodes, (size_t)nc * sizeof *n);
        if (!n)
            return -ENOMEM;
        p->nodes = n;
        p->cnodes = nc;
    }
    bvh_node *n = &p->nodes[p->nnodes];
    memset(n, 0, sizeof *n);
    n->name = malloc(nlen + 1);
    if (!n->name)
        return -ENOMEM;
    memcpy(n->name, name, nlen);
    n->name[nlen] = 0;
    n->parent = parent;
    n->is_end = is_end;
    return p->nnodes++;
}

static int parse_offset(bvh *p, bvh_node *n, char *err)
{
    for (int a = 0; a < 3; a++) {
        int r = tok_num(p, &n->offset[a], "an OFFSET coordinate", err);
        if (r)
            return r;
    }
    return 0;
}

/* Parses a ROOT/JOINT body after its keyword; the name is the rest of the keyword's line. */
static int parse_joint(bvh *p, int parent, int depth, char *err)
{
    if (depth > BVH_MAX_DEPTH)
        return mdl__err(err, MDL_EFORMAT, "%s:%d: joints nested deeper than %d", p->name, p->line,
                        BVH_MAX_DEPTH);
    /* name: rest of the line, trimmed; a trailing '{' opens the body */
    size_t a = p->pos;
    while (a < p->len && (p->s[a] == ' ' || p->s[a] == '\t'))
        a++;
    size_t e = a;
    while (e < p->len && p->s[e] != '\n' && p->s[e] != '\r')
        e++;
    size_t b = e;
    while (b > a && isspace((unsigned char)p->s[b - 1]))
        b--;
    int brace = 0;
    if (b > a && p->s[b - 1] == '{') {
        brace = 1;
        b--;
        while (b > a && isspace((unsigned char)p->s[b - 1]))
            b--;
    }
    if (b == a)
        return mdl__err(err, MDL_EFORMAT, "%s:%d: joint without a name", p->name, p->line);
    int id = add_node(p, p->s + a, b - a, parent, 0);
    if (id < 0)
        return mdl__err(err, -ENOMEM, "%s: out of memory", p->name);
    p->pos = e;
    int r;
    if (!brace && (r = expect(p, "{", err)) != 0)
        return r;
    for (;;) {
        if (!next_tok(p))
            return mdl__err(err, MDL_EFORMAT, "%s:%d: file ends inside joint %s", p->name, p->line,
                            p->nodes[id].name);
        if (!strcasecmp(p->tok, "OFFSET")) {
            if ((r = parse_offset(p, &p->nodes[id], err)) != 0)
                return r;
        } else if (!strcasecmp(p->tok, "CHANNELS")) {
            double n;
            if ((r = tok_num(p, &n, "the channel count", err)) != 0)
                return r;
            if (n < 0 || n > 6 || n != floor(n) || p->nodes[id].nch)
                return mdl__err(err, MDL_EFORMAT, "%s:%d: joint %s: invalid CHANNELS %g", p->name,
                                p->tok_line, p->nodes[id].name, n);
            p->nodes[id].nch = (int)n;
            p->nodes[id].ch0 = p->nch;
            for (int k = 0; k < (int)n; k++) {
                if (!next_tok(p))
                    return mdl__err(err, MDL_EFORMAT, "%s:%d: file ends in CHANNELS", p->name,
                                    p->line);
                static const char *kinds[] = {"Xposition", "Yposition", "Zposition",
                                              "Xrotation", "Yrotation", "Zrotation"};
                int kind = -1;
                for (int c = 0; c < 6; c++)
                    if (!strcasecmp(p->tok, kinds[c]))
                        kind = c;
                if (kind < 0)
                    return mdl__err(err, MDL_EFORMAT, "%s:%d: unknown channel '%s'", p->name,
                                    p->tok_line, p->tok);
                if (p->nch == p->cch) {
                    int nc = p->cch ? 2 * p->cch : 256;
                    int *c = realloc(p->ch, (size_t)nc * sizeof *c);
                    if (!c)
                        return mdl__err(err, -ENOMEM, "%s: out of memory", p->name);
                    p->ch = c;
                    p->cch = nc;
                }
                p->ch[p->nch++] = kind;
            }
        } else if (!strcasecmp(p->tok, "JOINT")) {
            if ((r = parse_joint(p, id, depth + 1, err)) != 0)
                return r;
        } else if (!strcasecmp(p->tok, "End")) {
            if ((r = expect(p, "Site", err)) != 0 || (r = expect(p, "{", err)) != 0 ||
                (r = expect(p, "OFFSET", err)) != 0)
                return r;
            char nm[160];
            int n = snprintf(nm, sizeof nm, "%.150s_End", p->nodes[id].name);
            int eid = add_node(p, nm, (size_t)n, id, 1);
            if (eid < 0)
                return mdl__err(err, -ENOMEM, "%s: out of memory", p->name);
            if ((r = parse_offset(p, &p->nodes[eid], err)) != 0 || (r = expect(p, "}", err)) != 0)
                return r;
        } else if (!strcmp(p->tok, "}")) {
            return 0;
        } else {
            return mdl__err(err, MDL_EFORMAT, "%s:%d: unexpected '%s' in joint %s", p->name,
                            p->tok_line, p->tok, p->nodes[id].name);
        }
    }
}

/* M = M * R_axis(deg) for a 3x3 row-major matrix. */
static void rotate(double M[9], int axis, double deg)
{
    double t = deg * (M_PI / 180.0), c = cos(t), s = sin(t);
    double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    if (axis == 0) {
        R[4] = c, R[5] = -s, R[7] = s, R[8] = c;
    } else if (axis == 1) {
        R[0] = c, R[2] = s, R[6] = -s, R[8] = c;
    } else {
        R[0] = c, R[1] = -s, R[3] = s, R[4] = c;
    }
    double o[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            o[3 * i + j] = M[3 * i] * R[j] + M[3 * i + 1] * R[3 + j] + M[3 * i + 2] * R[6 + j];
    memcpy(M, o, sizeof o);
}

/* Joint positions of one frame from channel values `v` into P (nnodes x 3), and each segment's
 * rotation into Q (nnodes x 4, w x y z: the parent's world rotation, a root's own), using Rw/Xw
 * (nnodes x 9, nnodes x 3) as workspace. */
static void fk(const bvh *p, const double *v, double *Rw, double *Xw, float *P, float *Q)
{
    for (int j = 0; j < p->nnodes; j++) {
        const bvh_node *n = &p->nodes[j];
        double t[3] = {n->offset[0], n->offset[1], n->offset[2]};
        double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        for (int k = 0; k < n->nch; k++) {
            int kind = p->ch[n->ch0 + k];
            if (kind <= CH_ZPOS)
                t[kind] = v[n->ch0 + k];
            else
                rotate(R, kind - CH_XROT, v[n->ch0 + k]);
        }
        double *Rj = Rw + 9 * j, *xj = Xw + 3 * j;
        if (n->parent < 0) {
            memcpy(Rj, R, sizeof R);
            memcpy(xj, t, sizeof t);
        } else {
            const double *Rp = Rw + 9 * n->parent, *xp = Xw + 3 * n->parent;
            for (int i = 0; i < 3; i++) {
                xj[i] = xp[i] + Rp[3 * i] * t[0] + Rp[3 * i + 1] * t[1] + Rp[3 * i + 2] * t[2];
                for (int c = 0; c < 3; c++)
                    Rj[3 * i + c] = Rp[3 * i] * R[c] + Rp[3 * i + 1] * R[3 + c] +
                                    Rp[3 * i + 2] * R[6 + c];
            }
        }
        for (int i = 0; i < 3; i++)
            P[3 * j + i] = (float)xj[i];
        double q[4];
        mdl__mat_to_quat(n->parent < 0 ? Rj : Rw + 9 * n->parent, q);
        for (int i = 0; i < 4; i++)
            Q[4 * j + i] = (float)q[i];
    }
}

int mdl_markers_parse_bvh(const char *buf, size_t len, const char *name, const mdl_marker_opts *o,
                          mdl_markers **out, char *err)
{
    *out = NULL;
    if (!name)
        name = "<bvh>";
    bvh p = {.len = len, .line = 1, .name = name};
    mdl_markers *m = NULL;
    double *work = NULL;
    int r;
    double scale;
    int up;
    if ((r = mdl__marker_opts_resolve(o, 0, MDL_UP_Y, &scale, &up, name, err)) != 0)
        return r;
    p.s = malloc(len + 1);
    if (!p.s)
        return mdl__err(err, -ENOMEM, "%s: out of memory", name);
    memcpy(p.s, buf, len);
    p.s[len] = 0;
    if ((r = expect(&p, "HIERARCHY", err)) != 0)
        goto done;
    for (;;) {
        if (!next_tok(&p)) {
            r = mdl__err(err, MDL_EFORMAT, "%s:%d: file ends before MOTION", name, p.line);
            goto done;
        }
        if (!strcasecmp(p.tok, "ROOT")) {
            if ((r = parse_joint(&p, -1, 0, err)) != 0)
                goto done;
        } else if (!strcasecmp(p.tok, "MOTION")) {
            break;
        } else {
            r = mdl__err(err, MDL_EFORMAT, "%s:%d: '%s' where ROOT or MOTION was expected", name,
                         p.tok_line, p.tok);
            goto done;
        }
    }
    if (p.nnodes == 0) {
        r = mdl__err(err, MDL_EFORMAT, "%s:%d: no ROOT before MOTION", name, p.line);
        goto done;
    }
    double frames, dt;
    if ((r = expect(&p, "Frames:", err)) != 0 ||
        (r = tok_num(&p, &frames, "the frame count", err)) != 0 ||
        (r = expect(&p, "Frame", err)) != 0 || (r = expect(&p, "Time:", err)) != 0 ||
        (r = tok_num(&p, &dt, "the frame time", err)) != 0)
        goto done;
    /* every value takes at least two bytes ("0 "), which bounds an honest frame count */
    if (frames < 0 || frames != floor(frames) ||
        frames * (p.nch ? p.nch : 1) > (double)(len - p.pos) / 2 + 1) {
        r = mdl__err(err, MDL_EFORMAT,
                     "%s:%d: Frames: %g does not fit the %zu bytes of motion data (%d channels)",
                     name, p.tok_line, frames, len - p.pos, p.nch);
        goto done;
    }
    r = mdl_markers_create((int)frames, p.nnodes, dt > 0 && dt < 1e6 ? 1.0 / dt : 0, &m, err);
    if (r != 0) {
        char tmp[MDL_ERR_LEN];
        snprintf(tmp, sizeof tmp, "%s", err ? err : "");
        r = mdl__err(err, r, "%s: %s", name, tmp);
        goto done;
    }
    for (int j = 0; j < p.nnodes; j++) {
        if (mdl__markers_set_name(m, j, p.nodes[j].name, strlen(p.nodes[j].name))) {
            r = mdl__err(err, -ENOMEM, "%s: out of memory", name);
            goto done;
        }
    }
    if (mdl__markers_unique_names(m) || mdl__markers_alloc_rot(m)) {
        r = mdl__err(err, -ENOMEM, "%s: out of memory", name);
        goto done;
    }
    for (int j = 0; j < p.nnodes; j++)
        m->parent[j] = p.nodes[j].parent;
    work = mdl__calloc((size_t)p.nch + 12 * (size_t)p.nnodes, sizeof *work);
    if (!work) {
        r = mdl__err(err, -ENOMEM, "%s: out of memory", name);
        goto done;
    }
    double *v = work, *Rw = work + p.nch, *Xw = Rw + 9 * (size_t)p.nnodes;
    for (int f = 0; f < m->frames; f++) {
        for (int k = 0; k < p.nch; k++) {
            if (!next_tok(&p)) {
                r = mdl__err(err, MDL_EFORMAT,
                             "%s:%d: truncated: Frames: %d but the data ends in frame %d "
                             "(channel %d of %d)",
                             name, p.line, m->frames, f + 1, k + 1, p.nch);
                goto done;
            }
            char *end;
            v[k] = strtod(p.tok, &end);
            if (end == p.tok || *end || !isfinite(v[k])) {
                r = mdl__err(err, MDL_EFORMAT, "%s:%d: frame %d channel %d: '%s' is not a number",
                             name, p.tok_line, f + 1, k + 1, p.tok);
                goto done;
            }
        }
        fk(&p, v, Rw, Xw, m->P + 3 * (size_t)f * (size_t)p.nnodes,
           m->rot + 4 * (size_t)f * (size_t)p.nnodes);
    }
    if (next_tok(&p)) {
        r = mdl__err(err, MDL_EFORMAT, "%s:%d: '%s' after the last of %d frames", name,
                     p.tok_line, p.tok, m->frames);
        goto done;
    }
    if (o && o->rest) {
        /* the skeleton's rest pose: every channel zero (model.h, mdl_marker_opts.rest) */
        memset(v, 0, (size_t)p.nch * sizeof *v);
        fk(&p, v, Rw, Xw, m->P, m->rot);
        m->frames = m->frames > 0 ? 1 : 0;
        if (m->frames == 0) {
            r = mdl__err(err, MDL_EFORMAT, "%s: no frame to hold the rest pose", name);
            goto done;
        }
    }
    memset(m->valid, 1, (size_t)m->frames * (size_t)m->count);
    if (scale == 0) {
        /* guess the unit from the first frame's height along the up axis */
        mdl__markers_convert(m, 1.0, up);
        scale = 1.0;
        if (m->frames > 0) {
            float lo = m->P[1], hi = m->P[1];
            for (int j = 1; j < m->count; j++) {
                float y = m->P[3 * j + 1];
                lo = y < lo ? y : lo;
                hi = y > hi ? y : hi;
            }
            double h = (double)hi - lo;
            static const double units[] = {1.0, 0.01, 0.001, 0.0254, 0.056444};
            if (h > 0)
                for (size_t u = 1; u < sizeof units / sizeof units[0]; u++)
                    if (fabs(h * units[u] - 1.75) < fabs(h * scale - 1.75))
                        scale = units[u];
        }
        mdl__markers_convert(m, scale, MDL_UP_Y);
    } else {
        mdl__markers_convert(m, scale, up);
    }
    *out = m;
    m = NULL;
done:
    mdl_markers_destroy(m);
    for (int j = 0; j < p.nnodes; j++)
        free(p.nodes[j].name);
    free(p.nodes);
    free(p.ch);
    free(p.s);
    free(work);
    return r;
}
