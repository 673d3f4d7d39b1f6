/* meshgraph.h - the mesh edge graph and geodesic distances on it.
 *
 * Geodesic distance is approximated by shortest paths along mesh edges (Dijkstra with a binary
 * heap), weighted by edge length in a given pose. Used for the blend weights of paper 2012
 * Sec. 5.3 eq. (8) and for growing cluster overlaps (Sec. 4.5). Training only: allocates. */
#ifndef MESHSTEER_MODEL_MESHGRAPH_H
#define MESHSTEER_MODEL_MESHGRAPH_H

#include <stdint.h>

typedef struct mdl_graph {
    int nv;
    int *off;  /* nv + 1 */
    int *nbr;  /* neighbour vertex indices, each undirected edge stored twice */
} mdl_graph;

int mdl__graph_init(mdl_graph *g, int nv, const uint32_t *F, int nf, char *err);
void mdl__graph_fini(mdl_graph *g);

/* Multi-source Dijkstra from `src` (nsrc vertices, distance 0), edge lengths measured on X
 * (nv x 3 floats), restricted to vertices with allowed[v] != 0 when allowed is non-NULL.
 * dist (nv) gets INFINITY for unreached vertices. */
int mdl__geodesic(const mdl_graph *g, const float *X, const int *src, int nsrc,
                  const uint8_t *allowed, double *dist, char *err);

#endif
