/* cluster.h - near-rigid clustering (paper 2012 Sec. 4.5); the method is described in cluster.c.
 *
 * X: T x nv x 3 doubles, the training frames in the body frame (frame 0 is the reference).
 * clusters > 0 asks for that many; otherwise clusters are split until each one's RMS rigid
 * residual is <= tol (same unit as X), at most max_clusters. Clusters are connected and have at
 * least min_size vertices. part (nv) receives 0-based cluster ids, part_rms (max_clusters + 1
 * entries) the RMS residual per cluster. Training only: allocates. */
#ifndef MESHSTEER_MODEL_CLUSTER_H
#define MESHSTEER_MODEL_CLUSTER_H

#include "core/meshgraph.h"
#include "model.h"

int mdl__cluster(const double *X, int T, int nv, const mdl_graph *g, int clusters,
                 int max_clusters, double tol, int min_size, int *part, int *nparts,
                 double *part_rms, mdl_progress_fn progress, void *ud, char *err);

/* The same, and with snap_part non-NULL also the partition where a run with max_clusters = snap_k
 * (clusters = 0) would have stopped: the loop splits one cluster at a time whatever the bound, so
 * that run is a prefix of this one (snap_part nv ids, *snap_n clusters, snap_rms their residuals;
 * *snap_n must be 0 on entry). The option selection (select.h) reads both from one run. */
int mdl__cluster_snap(const double *X, int T, int nv, const mdl_graph *g, int clusters,
                      int max_clusters, double tol, int min_size, int *part, int *nparts,
                      double *part_rms, int snap_k, int *snap_part, int *snap_n,
                      double *snap_rms, mdl_progress_fn progress, void *ud, char *err);

#endif
