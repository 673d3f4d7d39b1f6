/* tri_tri.c - the triangle-triangle test of tri_tri.h (Möller 1997, in its edge form). */
#include "core/tri_tri.h"

#include <math.h>

static void sub(const double a[3], const double b[3], double o[3])
{
    o[0] = a[0] - b[0];
    o[1] = a[1] - b[1];
    o[2] = a[2] - b[2];
}

static void cross(const double a[3], const double b[3], double o[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

static double dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* det[b - a, c - a, d - a] */
static double orient(const double a[3], const double b[3], const double c[3], const double d[3])
{
    double u[3], v[3], w[3], n[3];
    sub(b, a, u);
    sub(c, a, v);
    sub(d, a, w);
    cross(u, v, n);
    return dot(n, w);
}

static int sgn(double x)
{
    return (x > 0) - (x < 0);
}

/* 2-D: orientation of c against segment ab */
static double orient2(const double *a, const double *b, const double *c)
{
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

static int on_box2(const double *a, const double *b, const double *c)
{
    return fmin(a[0], b[0]) <= c[0] && c[0] <= fmax(a[0], b[0]) && fmin(a[1], b[1]) <= c[1] &&
           c[1] <= fmax(a[1], b[1]);
}

/* closed 2-D segments ab and cd meet */
static int seg_seg2(const double *a, const double *b, const double *c, const double *d)
{
    double o1 = orient2(a, b, c), o2 = orient2(a, b, d), o3 = orient2(c, d, a), o4 = orient2(c, d, b);
    if (sgn(o1) * sgn(o2) < 0 && sgn(o3) * sgn(o4) < 0)
        return 1;
    return (o1 == 0 && on_box2(a, b, c)) || (o2 == 0 && on_box2(a, b, d)) ||
           (o3 == 0 && on_box2(c, d, a)) || (o4 == 0 && on_box2(c, d, b));
}

/* 2-D point p in the closed triangle t (3 points) */
static int in_tri2(const double t[3][2], const double *p)
{
    int s0 = sgn(orient2(t[0], t[1], p)), s1 = sgn(orient2(t[1], t[2], p)), s2 = sgn(orient2(t[2], t[0], p));
    return !((s0 < 0 || s1 < 0 || s2 < 0) && (s0 > 0 || s1 > 0 || s2 > 0));
}

/* points a (na of them: 2 a segment, 3 a triangle) and triangle b, in the plane with normal n */
static int coplanar(const double a[][3], int na, const double b[3][3], const double n[3])
{
    int ax = 0;
    for (int c = 1; c < 3; c++)
        if (fabs(n[c]) > fabs(n[ax]))
            ax = c;
    int u = ax == 0 ? 1 : 0, v = ax == 2 ? 1 : 2;
    double A[3][2], B[3][2];
    for (int k = 0; k < na; k++)
        A[k][0] = a[k][u], A[k][1] = a[k][v];
    for (int k = 0; k < 3; k++)
        B[k][0] = b[k][u], B[k][1] = b[k][v];
    int ea = na == 2 ? 1 : 3;
    for (int i = 0; i < ea; i++)
        for (int j = 0; j < 3; j++)
            if (seg_seg2(A[i], A[(i + 1) % na], B[j], B[(j + 1) % 3]))
                return 1;
    if (in_tri2(B, A[0]))
        return 1;
    return na == 3 && in_tri2(A, B[0]);
}

/* the orientations of x[0..2] against the plane of t (|n| x the signed distance), those within
 * tol 0 */
static void dists(const double t[3][3], const double x[3][3], double tol, double d[3])
{
    for (int k = 0; k < 3; k++) {
        d[k] = orient(t[0], t[1], t[2], x[k]);
        if (fabs(d[k]) <= tol)
            d[k] = 0;
    }
}

/* edge (p[i], p[j]) of a triangle with distances d to the plane of t: does it cross t */
static int edge_cross(const double p[3][3], const double d[3], int i, int j, const double t[3][3],
                      const double nt[3])
{
    if (sgn(d[i]) * sgn(d[j]) > 0)
        return 0;
    if (d[i] == 0 && d[j] == 0) {
        double s[2][3] = {{p[i][0], p[i][1], p[i][2]}, {p[j][0], p[j][1], p[j][2]}};
        return coplanar(s, 2, t, nt);
    }
    double o0 = orient(p[i], p[j], t[0], t[1]), o1 = orient(p[i], p[j], t[1], t[2]),
           o2 = orient(p[i], p[j], t[2], t[0]);
    return (o0 >= 0 && o1 >= 0 && o2 >= 0) || (o0 <= 0 && o1 <= 0 && o2 <= 0);
}

int mdl__tri_tri(const float *p0, const float *p1, const float *p2, const float *q0,
                 const float *q1, const float *q2)
{
    double P[3][3], Q[3][3];
    const float *pp[3] = {p0, p1, p2}, *qq[3] = {q0, q1, q2};
    double size = 0;
    for (int k = 0; k < 3; k++)
        for (int c = 0; c < 3; c++) {
            P[k][c] = pp[k][c];
            Q[k][c] = qq[k][c];
            size = fmax(size, fmax(fabs(P[k][c] - P[0][c]), fabs(Q[k][c] - Q[0][c])));
        }
    double e1[3], e2[3], np[3], nq[3];
    sub(P[1], P[0], e1);
    sub(P[2], P[0], e2);
    cross(e1, e2, np);
    sub(Q[1], Q[0], e1);
    sub(Q[2], Q[0], e2);
    cross(e1, e2, nq);
    double eps = 1e-7 * size, lp = dot(np, np), lq = dot(nq, nq);
    double dq[3], dp[3];
    if (lp == 0 || lq == 0) { /* a degenerate triangle (a segment or a point): its edges */
        if (lp == 0 && lq == 0)
            return 0;
        const double(*A)[3] = lp == 0 ? P : Q, (*B)[3] = lp == 0 ? Q : P;
        const double *nb = lp == 0 ? nq : np;
        double d[3];
        dists(B, A, eps * sqrt(lp + lq), d);
        for (int i = 0; i < 3; i++)
            if (edge_cross(A, d, i, (i + 1) % 3, B, nb))
                return 1;
        return 0;
    }
    dists(P, Q, eps * sqrt(lp), dq); /* Q's corners against P's plane */
    if ((dq[0] > 0 && dq[1] > 0 && dq[2] > 0) || (dq[0] < 0 && dq[1] < 0 && dq[2] < 0))
        return 0;
    dists(Q, P, eps * sqrt(lq), dp);
    if ((dp[0] > 0 && dp[1] > 0 && dp[2] > 0) || (dp[0] < 0 && dp[1] < 0 && dp[2] < 0))
        return 0;
    if (dq[0] == 0 && dq[1] == 0 && dq[2] == 0)
        return coplanar(P, 3, Q, np);
    for (int i = 0; i < 3; i++) {
        int j = (i + 1) % 3;
        if (edge_cross(P, dp, i, j, Q, nq) || edge_cross(Q, dq, i, j, P, np))
            return 1;
    }
    return 0;
}
