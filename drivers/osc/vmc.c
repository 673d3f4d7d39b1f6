/* vmc.c - the VMC humanoid skeleton and its forward kinematics (vmc.h). */
#include "vmc.h"

#include <errno.h>
#include <math.h>
#include <string.h>

/* Bones in an order where every parent comes before its children; parent -1 is the root. */
static const struct {
    const char *name;
    int parent;
} bones[DRV_VMC_BONES] = {
    /* body (DRV_VMC_BODY = 25) */
    {"Hips", -1},           /* 0 */
    {"Spine", 0},           /* 1 */
    {"Chest", 1},           /* 2 */
    {"UpperChest", 2},      /* 3 */
    {"Neck", 3},            /* 4 */
    {"Head", 4},            /* 5 */
    {"LeftEye", 5},         /* 6 */
    {"RightEye", 5},        /* 7 */
    {"Jaw", 5},             /* 8 */
    {"LeftShoulder", 3},    /* 9 */
    {"LeftUpperArm", 9},    /* 10 */
    {"LeftLowerArm", 10},   /* 11 */
    {"LeftHand", 11},       /* 12 */
    {"RightShoulder", 3},   /* 13 */
    {"RightUpperArm", 13},  /* 14 */
    {"RightLowerArm", 14},  /* 15 */
    {"RightHand", 15},      /* 16 */
    {"LeftUpperLeg", 0},    /* 17 */
    {"LeftLowerLeg", 17},   /* 18 */
    {"LeftFoot", 18},       /* 19 */
    {"LeftToes", 19},       /* 20 */
    {"RightUpperLeg", 0},   /* 21 */
    {"RightLowerLeg", 21},  /* 22 */
    {"RightFoot", 22},      /* 23 */
    {"RightToes", 23},      /* 24 */
    /* fingers */
    {"LeftThumbProximal", 12}, {"LeftThumbIntermediate", 25}, {"LeftThumbDistal", 26},
    {"LeftIndexProximal", 12}, {"LeftIndexIntermediate", 28}, {"LeftIndexDistal", 29},
    {"LeftMiddleProximal", 12}, {"LeftMiddleIntermediate", 31}, {"LeftMiddleDistal", 32},
    {"LeftRingProximal", 12}, {"LeftRingIntermediate", 34}, {"LeftRingDistal", 35},
    {"LeftLittleProximal", 12}, {"LeftLittleIntermediate", 37}, {"LeftLittleDistal", 38},
    {"RightThumbProximal", 16}, {"RightThumbIntermediate", 40}, {"RightThumbDistal", 41},
    {"RightIndexProximal", 16}, {"RightIndexIntermediate", 43}, {"RightIndexDistal", 44},
    {"RightMiddleProximal", 16}, {"RightMiddleIntermediate", 46}, {"RightMiddleDistal", 47},
    {"RightRingProximal", 16}, {"RightRingIntermediate", 49}, {"RightRingDistal", 50},
    {"RightLittleProximal", 16}, {"RightLittleIntermediate", 52}, {"RightLittleDistal", 53},
};

int drv_vmc_bone_index(const char *name)
{
    for (int i = 0; name && i < DRV_VMC_BONES; i++)
        if (!strcmp(name, bones[i].name))
            return i;
    return -1;
}

const char *drv_vmc_bone_name(int i)
{
    return i >= 0 && i < DRV_VMC_BONES ? bones[i].name : NULL;
}

static void identity(float p[3], float q[4])
{
    p[0] = p[1] = p[2] = 0;
    q[0] = q[1] = q[2] = 0;
    q[3] = 1;
}

void drv_vmc_init(drv_vmc *v)
{
    memset(v, 0, sizeof *v);
    for (int b = 0; b < DRV_VMC_BONES; b++)
        identity(v->lp[b], v->lq[b]);
    identity(v->rp, v->rq);
}

static int set(float p[3], float q[4], const double ip[3], const double iq[4])
{
    double n = 0;
    for (int k = 0; k < 4; k++)
        n += iq[k] * iq[k];
    for (int k = 0; k < 3; k++)
        if (!isfinite(ip[k]))
            return -EINVAL;
    if (!isfinite(n) || n < 1e-12)
        return -EINVAL;
    n = 1 / sqrt(n);
    for (int k = 0; k < 3; k++)
        p[k] = (float)ip[k];
    for (int k = 0; k < 4; k++)
        q[k] = (float)(iq[k] * n);
    return 0;
}

int drv_vmc_set_bone(drv_vmc *v, int bone, const double p[3], const double q[4])
{
    if (bone < 0 || bone >= DRV_VMC_BONES)
        return -EINVAL;
    int r = set(v->lp[bone], v->lq[bone], p, q);
    if (r == 0)
        v->have[bone] = 1;
    return r;
}

int drv_vmc_set_root(drv_vmc *v, const double p[3], const double q[4])
{
    return set(v->rp, v->rq, p, q);
}

/* q = a b (Hamilton product, x y z w) */
static void qmul(const float a[4], const float b[4], float q[4])
{
    float x = a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1];
    float y = a[3] * b[1] - a[0] * b[2] + a[1] * b[3] + a[2] * b[0];
    float z = a[3] * b[2] + a[0] * b[1] - a[1] * b[0] + a[2] * b[3];
    float w = a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2];
    q[0] = x, q[1] = y, q[2] = z, q[3] = w;
}

/* r = q v q* for a unit quaternion */
static void qrot(const float q[4], const float v[3], float r[3])
{
    /* t = 2 (q.xyz x v); r = v + w t + q.xyz x t */
    float t[3] = {2 * (q[1] * v[2] - q[2] * v[1]), 2 * (q[2] * v[0] - q[0] * v[2]),
                  2 * (q[0] * v[1] - q[1] * v[0])};
    r[0] = v[0] + q[3] * t[0] + (q[1] * t[2] - q[2] * t[1]);
    r[1] = v[1] + q[3] * t[1] + (q[2] * t[0] - q[0] * t[2]);
    r[2] = v[2] + q[3] * t[2] + (q[0] * t[1] - q[1] * t[0]);
}

void drv_vmc_solve(drv_vmc *v)
{
    float wq[DRV_VMC_BONES][4], wpu[DRV_VMC_BONES][3]; /* world, Unity frame */
    for (int b = 0; b < DRV_VMC_BONES; b++) {
        int p = bones[b].parent;
        const float *pp = p < 0 ? v->rp : wpu[p], *pq = p < 0 ? v->rq : wq[p];
        float t[3];
        qrot(pq, v->lp[b], t);
        for (int k = 0; k < 3; k++)
            wpu[b][k] = pp[k] + t[k];
        qmul(pq, v->lq[b], wq[b]);
        v->wp[b][0] = wpu[b][0];
        v->wp[b][1] = wpu[b][1];
        v->wp[b][2] = -wpu[b][2];
    }
}
