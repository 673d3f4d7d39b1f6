/* asf_amc.c - Acclaim skeleton (ASF) and motion (AMC) files read as markers by forward kinematics,
 * like bvh.c: every joint position becomes a marker.
 *
 * Format (Acclaim; see Lander 1998 and the CMU/HDM05 files in ../shared/data/mocap/asf_amc):
 *   ASF: line-oriented sections, each opened by a ':keyword' line:
 *     :units      "length L" (file lengths are inches x L; CMU and HDM05 use 0.45), "angle deg|rad"
 *     :root       "order TX TY TZ RX RY RZ" (the root's AMC values), "axis XYZ", "position x y z",
 *                 "orientation a b c"
 *     :bonedata   blocks "begin ... end" with id, name, direction (unit, world frame at rest),
 *                 length, "axis a b c ORDER" (the bone's local frame), "dof rx ry rz ..." (its AMC
 *                 values, in this order) and limits (skipped)
 *     :hierarchy  "begin", lines "parent child child ...", "end"
 *     others (:version, :name, :documentation, ...) are skipped.
 *   AMC: header lines starting with '#' or ':' (comments, ":FULLY-SPECIFIED", ":DEGREES"), then
 *     per frame a line holding the frame number alone and one line per bone "name v1 v2 ...", the
 *     values in its dof order (the root's in its :root order). A bone missing from a frame keeps 0.
 *   Lines may end in LF or CRLF; bytes above 127 (a Latin-1 comment) are only allowed in comments
 *   and skipped sections.
 * Forward kinematics (column vectors; R_X(a) a rotation about x by a, etc.):
 *   C_b = the bone's axis rotation, composed in its ORDER as fixed axes (XYZ: R_Z R_Y R_X);
 *   M_b = the frame's dof rotations, likewise in dof order (rx ry rz: R_z R_y R_x);
 *   root:  R = C M C^T,  x = (TX, TY, TZ) (the ASF position when the AMC has none);
 *   bone:  R_b = R_parent C_b M_b C_b^T,  x_b = x_parent + R_b (length_b direction_b),
 *   i.e. x_b is the bone's far end. Translation and length dofs (tx ty tz l) are read and ignored.
 * Markers: "root", then every bone (named after it, its far end), in ASF order; all valid.
 * Joint rotations (mdl_markers.rot, parent): a bone's segment (its parent's end to its own) turns
 * with R_b, so rot[b] = R_b, parent[b] = its parent bone's marker (the root's: "root"), rot[root] =
 * R; every R is the identity in the rest pose (C M C^T with M = I).
 * With opts->rest, or no AMC, one frame: the rest pose (every dof 0, the root at the ASF position).
 * Units: opts->scale, else 0.0254 / L metres per unit; up axis +Y by default; fps 120 (AMC files
 * carry no rate; CMU and HDM05 record at 120 Hz). */
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

#define LINE_MAX_LEN 4096
#define MAX_BONES 1024
#define MAX_DOF 7

enum { D_TX, D_TY, D_TZ, D_RX, D_RY, D_RZ, D_L };

typedef struct bone {
    char name[MDL_NAME_LEN];
    double dir[3], len;
    double C[9];          /* axis rotation, row-major */
    int ndof, dof[MAX_DOF];
    int parent;           /* -1: the root's child */
} bone;

typedef struct asf {
    int nb;
    bone *b;
    double unit_len, angle; /* angle: radians per file unit */
    int root_ndof, root_dof[MAX_DOF];
    double root_pos[3], root_C[9];
    int *order;           /* nb: parents before children */
} asf;

/* a line reader over a buffer that need not be NUL-terminated */
typedef struct lines {
    const char *buf;
    size_t len, pos;
    int line;
    char s[LINE_MAX_LEN + 1];
} lines;

/* next line into l->s (CR and the newline stripped); 0 at the end, -1 when too long */
static int next_line(lines *l)
{
    if (l->pos >= l->len)
        return 0;
    size_t a = l->pos, b = a;
    while (b < l->len && l->buf[b] != '\n')
        b++;
    l->pos = b < l->len ? b + 1 : b;
    l->line++;
    size_t n = b - a;
    while (n > 0 && (l->buf[a + n - 1] == '\r'))
        n--;
    if (n > LINE_MAX_LEN)
        return -1;
    memcpy(l->s, l->buf + a, n);
    l->s[n] = 0;
    for (size_t i = 0; i < n; i++)
        if (l->s[i] == 0 || l->s[i] == '\r' || l->s[i] == '\t')
            l->s[i] = ' ';
    return 1;
}

static char *skip_ws(char *s)
{
    while (*s == ' ')
        s++;
    return s;
}

/* the next whitespace-separated word of *s (NUL-terminated in place), or NULL */
static char *word(char **s)
{
    char *p = skip_ws(*s);
    if (!*p)
        return NULL;
    char *e = p;
    while (*e && *e != ' ')
        e++;
    if (*e)
        *e++ = 0;
    *s = e;
    return p;
}

static int num(char **s, double *v)
{
    char *w = word(s), *end;
    if (!w)
        return -1;
    *v = strtod(w, &end);
    return (*end || !isfinite(*v)) ? -1 : 0;
}

static void rot_axis(int ax, double a, double R[9])
{
    double c = cos(a), s = sin(a);
    memset(R, 0, 9 * sizeof *R);
    int i = (ax + 1) % 3, j = (ax + 2) % 3;
    R[4 * ax] = 1;
    R[3 * i + i] = c, R[3 * i + j] = -s;
    R[3 * j + i] = s, R[3 * j + j] = c;
}

static void mul(const double *A, const double *B, double *C)
{
    double T[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            T[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
    memcpy(C, T, sizeof T);
}

/* fixed-axis composition in the listed order: R = R_n ... R_1 (axes 0..2, angles in radians) */
static void euler(const int *axes, const double *ang, int n, double R[9])
{
    double A[9];
    static const double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    memcpy(R, I, sizeof I);
    for (int k = 0; k < n; k++) {
        rot_axis(axes[k], ang[k], A);
        mul(A, R, R);
    }
}

/* "XYZ" -> axes; -1 when malformed */
static int axis_order(const char *w, int axes[3])
{
    if (!w || strlen(w) != 3)
        return -1;
    for (int k = 0; k < 3; k++) {
        int c = toupper((unsigned char)w[k]);
        if (c < 'X' || c > 'Z')
            return -1;
        axes[k] = c - 'X';
    }
    return 0;
}

static int dof_code(const char *w)
{
    static const char *names[] = {"tx", "ty", "tz", "rx", "ry", "rz", "l"};
    for (int k = 0; k < 7; k++)
        if (strcasecmp(w, names[k]) == 0)
            return k;
    return -1;
}

static int find_bone(const asf *a, const char *name)
{
    for (int i = 0; i < a->nb; i++)
        if (strcmp(a->b[i].name, name) == 0)
            return i;
    return -1;
}

static int has_high_bytes(const char *s)
{
    for (; *s; s++)
        if ((unsigned char)*s > 127)
            return 1;
    return 0;
}

#define FAIL(...) do { r = mdl__err(err, MDL_EFORMAT, __VA_ARGS__); goto done; } while (0)

static int parse_asf(const char *buf, size_t len, const char *name, asf *a, char *err)
{
    lines l = {.buf = buf, .len = len};
    int r = 0, sec = 0, cap = 0, inbone = 0, inhier = 0, got;
    enum { S_OTHER, S_UNITS, S_ROOT, S_BONES, S_HIER };
    a->unit_len = 1;
    a->angle = M_PI / 180;
    static const double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    memcpy(a->root_C, I, sizeof I);
    static const int def_order[6] = {D_TX, D_TY, D_TZ, D_RX, D_RY, D_RZ};
    memcpy(a->root_dof, def_order, sizeof def_order);
    a->root_ndof = 6;
    double root_or[3] = {0, 0, 0};
    int root_axes[3] = {0, 1, 2}, have_hier = 0;
    while ((got = next_line(&l)) != 0) {
        if (got < 0)
            FAIL("%s:%d: line longer than %d bytes", name, l.line, LINE_MAX_LEN);
        char *s = skip_ws(l.s);
        if (*s == '#' || !*s)
            continue;
        if (*s == ':') {
            if (inbone)
                FAIL("%s:%d: '%s' inside a bone's begin ... end", name, l.line, s);
            char *p = s + 1, *kw = word(&p);
            sec = S_OTHER;
            if (kw && strcasecmp(kw, "units") == 0)
                sec = S_UNITS;
            else if (kw && strcasecmp(kw, "root") == 0)
                sec = S_ROOT;
            else if (kw && strcasecmp(kw, "bonedata") == 0)
                sec = S_BONES;
            else if (kw && strcasecmp(kw, "hierarchy") == 0)
                sec = S_HIER;
            if (sec == S_HIER)
                have_hier = 1;
            continue;
        }
        if (sec == S_OTHER)
            continue;
        if (has_high_bytes(s))
            FAIL("%s:%d: a byte above 127 outside a comment", name, l.line);
        char *p = s, *kw = word(&p);
        if (sec == S_UNITS) {
            double v;
            if (strcasecmp(kw, "length") == 0) {
                if (num(&p, &v) || !(v > 0))
                    FAIL("%s:%d: units length: expected a positive number", name, l.line);
                a->unit_len = v;
            } else if (strcasecmp(kw, "angle") == 0) {
                char *w = word(&p);
                if (w && strcasecmp(w, "rad") == 0)
                    a->angle = 1;
                else if (w && strcasecmp(w, "deg") == 0)
                    a->angle = M_PI / 180;
                else
                    FAIL("%s:%d: units angle: expected deg or rad", name, l.line);
            }
        } else if (sec == S_ROOT) {
            if (strcasecmp(kw, "order") == 0) {
                a->root_ndof = 0;
                for (char *w; (w = word(&p));) {
                    int d = dof_code(w);
                    if (d < 0 || d == D_L || a->root_ndof >= MAX_DOF)
                        FAIL("%s:%d: root order: '%s' is not TX TY TZ RX RY RZ", name, l.line, w);
                    a->root_dof[a->root_ndof++] = d;
                }
            } else if (strcasecmp(kw, "axis") == 0) {
                if (axis_order(word(&p), root_axes))
                    FAIL("%s:%d: root axis: expected an order such as XYZ", name, l.line);
            } else if (strcasecmp(kw, "position") == 0 || strcasecmp(kw, "orientation") == 0) {
                double *dst = tolower((unsigned char)kw[0]) == 'p' ? a->root_pos : root_or;
                for (int k = 0; k < 3; k++)
                    if (num(&p, &dst[k]))
                        FAIL("%s:%d: root %s: expected three numbers", name, l.line, kw);
            }
        } else if (sec == S_BONES) {
            if (strcasecmp(kw, "begin") == 0) {
                if (inbone)
                    FAIL("%s:%d: begin inside a bone", name, l.line);
                if (a->nb >= MAX_BONES)
                    FAIL("%s:%d: more than %d bones", name, l.line, MAX_BONES);
                if (a->nb == cap) {
                    cap = cap ? 2 * cap : 32;
                    bone *nbp = realloc(a->b, (size_t)cap * sizeof *nbp);
                    if (!nbp) {
                        r = mdl__err(err, -ENOMEM, "%s: out of memory", name);
                        goto done;
                    }
                    a->b = nbp;
                }
                bone *b = a->b + a->nb++;
                memset(b, 0, sizeof *b);
                memcpy(b->C, I, sizeof I);
                b->parent = -2; /* not in the hierarchy yet */
                inbone = 1;
            } else if (!inbone) {
                FAIL("%s:%d: '%s' outside a bone's begin ... end", name, l.line, kw);
            } else {
                bone *b = a->b + a->nb - 1;
                if (strcasecmp(kw, "end") == 0) {
                    if (!b->name[0])
                        FAIL("%s:%d: a bone without a name", name, l.line);
                    inbone = 0;
                } else if (strcasecmp(kw, "name") == 0) {
                    char *w = word(&p);
                    if (!w || strlen(w) >= MDL_NAME_LEN || strcasecmp(w, "root") == 0)
                        FAIL("%s:%d: bone name: expected a name of 1..%d bytes other than root",
                             name, l.line, MDL_NAME_LEN - 1);
                    if (find_bone(a, w) >= 0)
                        FAIL("%s:%d: bone '%s' named twice", name, l.line, w);
                    snprintf(b->name, sizeof b->name, "%s", w);
                } else if (strcasecmp(kw, "direction") == 0) {
                    for (int k = 0; k < 3; k++)
                        if (num(&p, &b->dir[k]))
                            FAIL("%s:%d: direction: expected three numbers", name, l.line);
                } else if (strcasecmp(kw, "length") == 0) {
                    if (num(&p, &b->len) || b->len < 0)
                        FAIL("%s:%d: length: expected a number >= 0", name, l.line);
                } else if (strcasecmp(kw, "axis") == 0) {
                    double xyz[3], ang[3];
                    int axes[3];
                    for (int k = 0; k < 3; k++)
                        if (num(&p, &xyz[k]))
                            FAIL("%s:%d: axis: expected three angles and an order", name, l.line);
                    if (axis_order(word(&p), axes))
                        FAIL("%s:%d: axis: expected an order such as XYZ", name, l.line);
                    for (int k = 0; k < 3; k++)
                        ang[k] = xyz[axes[k]] * a->angle; /* the angle about each axis, in order */
                    euler(axes, ang, 3, b->C);
                } else if (strcasecmp(kw, "dof") == 0) {
                    b->ndof = 0;
                    for (char *w; (w = word(&p));) {
                        int d = dof_code(w);
                        if (d < 0 || b->ndof >= MAX_DOF)
                            FAIL("%s:%d: dof: '%s' is not rx ry rz tx ty tz l (at most %d)", name,
                                 l.line, w, MAX_DOF);
                        b->dof[b->ndof++] = d;
                    }
                }
                /* id, limits and their continuation lines "(lo hi)", bodymass, cofmass: skipped */
            }
        } else if (sec == S_HIER) {
            if (strcasecmp(kw, "begin") == 0) {
                inhier = 1;
                continue;
            }
            if (strcasecmp(kw, "end") == 0) {
                inhier = 0;
                continue;
            }
            if (!inhier)
                FAIL("%s:%d: hierarchy line outside begin ... end", name, l.line);
            int par = strcasecmp(kw, "root") == 0 ? -1 : find_bone(a, kw);
            if (par < -1 || (par == -1 && strcasecmp(kw, "root") != 0))
                FAIL("%s:%d: hierarchy: unknown bone '%s'", name, l.line, kw);
            for (char *w; (w = word(&p));) {
                int c = find_bone(a, w);
                if (c < 0)
                    FAIL("%s:%d: hierarchy: unknown bone '%s'", name, l.line, w);
                if (a->b[c].parent != -2)
                    FAIL("%s:%d: hierarchy: bone '%s' has two parents", name, l.line, w);
                a->b[c].parent = par;
            }
        }
    }
    if (inbone)
        FAIL("%s: the last bone has no end", name);
    if (!have_hier && a->nb > 0)
        FAIL("%s: no :hierarchy", name);
    {
        double ang[3];
        for (int k = 0; k < 3; k++)
            ang[k] = root_or[root_axes[k]] * a->angle;
        euler(root_axes, ang, 3, a->root_C);
    }
    /* parents before children; a bone outside the hierarchy, or a cycle, is an error */
    a->order = mdl__calloc((size_t)a->nb + 1, sizeof *a->order);
    uint8_t *done_ = mdl__calloc((size_t)a->nb + 1, 1);
    if (!a->order || !done_) {
        free(done_);
        r = mdl__err(err, -ENOMEM, "%s: out of memory", name);
        goto done;
    }
    int k = 0;
    for (int pass = 0; pass <= a->nb && k < a->nb; pass++)
        for (int i = 0; i < a->nb; i++)
            if (!done_[i] && a->b[i].parent != -2 &&
                (a->b[i].parent == -1 || done_[a->b[i].parent])) {
                done_[i] = 1;
                a->order[k++] = i;
            }
    free(done_);
    for (int i = 0; i < a->nb && k < a->nb; i++)
        if (a->b[i].parent == -2)
            FAIL("%s: bone '%s' is not in the hierarchy", name, a->b[i].name);
    if (k < a->nb)
        FAIL("%s: the hierarchy has a cycle", name);
done:
    return r;
}

/* forward kinematics of one frame: v[0..root_ndof) the root's values, then each bone's ndof
 * values (in ASF order); P: (1 + nb) x 3 file units; Q: (1 + nb) x 4 the world rotations (w x y z);
 * W: 9 (1 + nb) scratch */
static void fk(const asf *a, const double *v, float *P, float *Q, double *W)
{
    double ang[MAX_DOF], M[9], T[9], x[3] = {a->root_pos[0], a->root_pos[1], a->root_pos[2]};
    int axes[MAX_DOF], n = 0, at = 0;
    for (int k = 0; k < a->root_ndof; k++, at++) {
        int d = a->root_dof[k];
        if (d <= D_TZ)
            x[d] = v[at];
        else if (d <= D_RZ)
            axes[n] = d - D_RX, ang[n++] = v[at] * a->angle;
    }
    euler(axes, ang, n, M);
    double *R0 = W;
    mul(a->root_C, M, T);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            R0[3 * i + j] = T[3 * i] * a->root_C[3 * j] + T[3 * i + 1] * a->root_C[3 * j + 1] +
                            T[3 * i + 2] * a->root_C[3 * j + 2];
    for (int c = 0; c < 3; c++)
        P[c] = (float)x[c];
    /* each bone's values start at off[b]: computed in ASF order */
    int off[MAX_BONES];
    for (int b = 0; b < a->nb; b++) {
        off[b] = at;
        at += a->b[b].ndof;
    }
    for (int o = 0; o < a->nb; o++) {
        int b = a->order[o];
        const bone *bn = a->b + b;
        n = 0;
        for (int k = 0; k < bn->ndof; k++) {
            int d = bn->dof[k];
            if (d >= D_RX && d <= D_RZ)
                axes[n] = d - D_RX, ang[n++] = v[off[b] + k] * a->angle;
        }
        euler(axes, ang, n, M);
        const double *Rp = bn->parent < 0 ? R0 : W + 9 * (1 + bn->parent);
        const float *xp = bn->parent < 0 ? P : P + 3 * (1 + bn->parent);
        double *R = W + 9 * (1 + b);
        mul(Rp, bn->C, T);
        mul(T, M, T);
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                R[3 * i + j] = T[3 * i] * bn->C[3 * j] + T[3 * i + 1] * bn->C[3 * j + 1] +
                               T[3 * i + 2] * bn->C[3 * j + 2];
        for (int c = 0; c < 3; c++) {
            double d = R[3 * c] * bn->dir[0] + R[3 * c + 1] * bn->dir[1] + R[3 * c + 2] * bn->dir[2];
            P[3 * (1 + b) + c] = (float)(xp[c] + bn->len * d);
        }
    }
    for (int b = 0; b <= a->nb; b++) {
        double q[4];
        mdl__mat_to_quat(W + 9 * b, q);
        for (int i = 0; i < 4; i++)
            Q[4 * b + i] = (float)q[i];
    }
}

static int is_frame_number(const char *s, long *fn)
{
    char *end;
    s = skip_ws((char *)s);
    if (!isdigit((unsigned char)*s))
        return 0;
    *fn = strtol(s, &end, 10);
    end = skip_ws(end);
    return *end == 0;
}

int mdl_markers_parse_asf_amc(const char *asf_buf, size_t asf_len, const char *amc_buf,
                              size_t amc_len, const char *name, const mdl_marker_opts *o,
                              mdl_markers **out, char *err)
{
    *out = NULL;
    asf a = {0};
    mdl_markers *m = NULL;
    double *v = NULL, *W = NULL;
    int r = parse_asf(asf_buf, asf_len, name, &a, err);
    if (r)
        goto done;
    double scale;
    int up;
    if ((r = mdl__marker_opts_resolve(o, 0.0254 / a.unit_len, MDL_UP_Y, &scale, &up, name, err)))
        goto done;
    int nval = a.root_ndof;
    for (int b = 0; b < a.nb; b++)
        nval += a.b[b].ndof;
    int rest = !amc_buf || (o && o->rest);
    /* count the frames: lines holding a number alone after the header */
    long frames = 0;
    lines l = {.buf = amc_buf, .len = rest ? 0 : amc_len};
    int got;
    while ((got = next_line(&l)) != 0) {
        long fn;
        if (got > 0 && is_frame_number(l.s, &fn))
            frames++;
    }
    if (rest)
        frames = 1;
    else if (frames == 0)
        FAIL("%s: the AMC file holds no frame", name);
    if ((size_t)frames * (size_t)(1 + a.nb) > MDL__MARKERS_MAX_SAMPLES)
        FAIL("%s: %ld frames of %d markers is too many", name, frames, 1 + a.nb);
    if ((r = mdl_markers_create((int)frames, 1 + a.nb, 120, &m, err)))
        goto done;
    r = mdl__markers_set_name(m, 0, "root", 4);
    for (int b = 0; b < a.nb && !r; b++)
        r = mdl__markers_set_name(m, 1 + b, a.b[b].name, strlen(a.b[b].name));
    v = mdl__calloc((size_t)nval + 1, sizeof *v);
    W = mdl__calloc(9 * ((size_t)a.nb + 1), sizeof *W);
    if (r || !v || !W || mdl__markers_unique_names(m) || mdl__markers_alloc_rot(m)) {
        r = mdl__err(err, -ENOMEM, "%s: out of memory", name);
        goto done;
    }
    for (int b = 0; b < a.nb; b++)
        m->parent[1 + b] = 1 + a.b[b].parent; /* -1 (the root's child) -> 0, "root" */
    if (rest) {
        fk(&a, v, m->P, m->rot, W);
    } else {
        lines L = {.buf = amc_buf, .len = amc_len};
        int f = -1, header = 1;
        while ((got = next_line(&L)) != 0) {
            if (got < 0)
                FAIL("%s:%d: line longer than %d bytes", name, L.line, LINE_MAX_LEN);
            char *s = skip_ws(L.s);
            if (!*s || *s == '#')
                continue;
            if (header && *s == ':')
                continue;
            long fn;
            if (is_frame_number(s, &fn)) {
                if (f >= 0)
                    fk(&a, v, m->P + 3 * (size_t)f * (size_t)m->count, m->rot + 4 * (size_t)f * (size_t)m->count, W);
                f++;
                header = 0;
                memset(v, 0, (size_t)nval * sizeof *v); /* a bone missing from a frame: 0 */
                continue;
            }
            if (f < 0)
                FAIL("%s:%d: '%s' before the first frame number", name, L.line, s);
            if (has_high_bytes(s))
                FAIL("%s:%d: a byte above 127 outside a comment", name, L.line);
            char *p = s, *bn = word(&p);
            int at, nd;
            if (strcasecmp(bn, "root") == 0) {
                at = 0, nd = a.root_ndof;
            } else {
                int b = find_bone(&a, bn);
                if (b < 0)
                    FAIL("%s:%d: frame %d: unknown bone '%s'", name, L.line, f + 1, bn);
                at = a.root_ndof;
                for (int i = 0; i < b; i++)
                    at += a.b[i].ndof;
                nd = a.b[b].ndof;
            }
            for (int k = 0; k < nd; k++)
                if (num(&p, &v[at + k]))
                    FAIL("%s:%d: frame %d: bone '%s' needs %d numbers", name, L.line, f + 1, bn,
                         nd);
            if (word(&p))
                FAIL("%s:%d: frame %d: bone '%s' has more than %d numbers", name, L.line, f + 1,
                     bn, nd);
        }
        fk(&a, v, m->P + 3 * (size_t)f * (size_t)m->count, m->rot + 4 * (size_t)f * (size_t)m->count, W);
    }
    memset(m->valid, 1, (size_t)m->frames * (size_t)m->count);
    mdl__markers_convert(m, scale, up);
    *out = m;
    m = NULL;
done:
    mdl_markers_destroy(m);
    free(a.b);
    free(a.order);
    free(v);
    free(W);
    return r;
}
