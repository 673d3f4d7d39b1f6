/* vmc.h - the VMC protocol's humanoid skeleton: bone names, hierarchy, forward kinematics.
 *
 * VMC (Virtual Motion Capture protocol, protocol.vmc.info) sends, over OSC, per frame:
 *   /VMC/Ext/Root/Pos  s name, f px py pz, f qx qy qz qw [, f sx sy sz ox oy oz]   (world)
 *   /VMC/Ext/Bone/Pos  s bone, f px py pz, f qx qy qz qw                          (local)
 * The bone names are Unity's HumanBodyBones; a bone's position and rotation are relative to its
 * parent bone (Unity's Transform.localPosition/localRotation), Hips relative to the root. Unity is
 * left-handed, Y up, metres.
 *
 * Forward kinematics (world = parent o local):
 *   R_b = R_parent(b) q_b,   p_b = p_parent(b) + R_parent(b) t_b
 * with the root as the parent of Hips; a bone never received is the identity, so a skeleton
 * without an optional bone (UpperChest, Neck, toes...) composes as Unity's would. The world
 * positions are then mirrored into our right-handed, Y-up frame: (x, y, z) -> (x, y, -z).
 * Scale (the root's optional s) is not applied. */
#ifndef MESHSTEER_DRIVERS_OSC_VMC_H
#define MESHSTEER_DRIVERS_OSC_VMC_H

#include <stdint.h>

#define DRV_VMC_BONES 55  /* HumanBodyBones without LastBone */
#define DRV_VMC_BODY 25   /* the first 25 of the name table: body bones, no fingers */

typedef struct drv_vmc {
    float lp[DRV_VMC_BONES][3], lq[DRV_VMC_BONES][4]; /* local, as received (Unity frame) */
    uint8_t have[DRV_VMC_BONES];                      /* received at least once */
    float rp[3], rq[4];                               /* root, world (Unity frame) */
    float wp[DRV_VMC_BONES][3];                       /* world positions, our frame (solve) */
} drv_vmc;

/* Index of a bone name (exact, as Unity spells it), -1 for none. */
int drv_vmc_bone_index(const char *name);
/* Name of bone i: the DRV_VMC_BODY body bones first (Hips ... RightToes), then the fingers. */
const char *drv_vmc_bone_name(int i);
void drv_vmc_init(drv_vmc *v);
/* -EINVAL when a value is not finite or the quaternion has no length; the pose is unchanged. */
int drv_vmc_set_bone(drv_vmc *v, int bone, const double p[3], const double q[4]);
int drv_vmc_set_root(drv_vmc *v, const double p[3], const double q[4]);
/* Fills wp for every bone from the current local transforms. */
void drv_vmc_solve(drv_vmc *v);

#endif
