/* test_cluster.c - near-rigid clustering (Sec. 4.5) splits a bending tube at its joint. */
#include "steer/cluster.h"
#include "core/meshgraph.h"
#include "model.h"
#include "test.h"
#include "model/tube.h"

int main(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *s;
    mdl_rig *rig;
    tube_create(30, &s, &rig);
    int nv = s->nv;
    double *X = malloc(sizeof(double) * 3 * (size_t)nv * s->frames);
    for (size_t i = 0; i < 3 * (size_t)nv * s->frames; i++)
        X[i] = s->V[i];
    mdl_graph g;
    ASSERT_OK(mdl__graph_init(&g, nv, s->F, s->nf, err), err);
    /* every interior vertex of a closed tube ring has 6 neighbours */
    ASSERT_INT_EQ(g.off[5 * TUBE_AROUND + 1] - g.off[5 * TUBE_AROUND], 6);
    int *part = malloc(sizeof(int) * (size_t)nv), np;
    double rms[9];
    ASSERT_OK(mdl__cluster(X, s->frames, nv, &g, 2, 8, 0, 4, part, &np, rms, NULL, NULL, err), err);
    ASSERT_INT_EQ(np, 2);
    /* the two segments end up in different clusters, each ring entirely in one */
    int a = part[1 * TUBE_AROUND], b = part[(TUBE_RINGS - 2) * TUBE_AROUND];
    ASSERT(a != b);
    for (int r = 0; r < TUBE_RINGS; r++) {
        double x = 2.0 * r / (TUBE_RINGS - 1);
        if (fabs(x - 1) < 0.2)
            continue; /* the joint region may go either way */
        for (int k = 0; k < TUBE_AROUND; k++)
            ASSERT_INT_EQ(part[r * TUBE_AROUND + k], x < 1 ? a : b);
    }
    /* automatic count: splitting stops once every part is rigid within the tolerance */
    ASSERT_OK(mdl__cluster(X, s->frames, nv, &g, 0, 8, 0.01, 4, part, &np, rms, NULL, NULL, err), err);
    ASSERT(np >= 2 && np <= 8);
    for (int c = 0; c < np; c++)
        ASSERT(rms[c] <= 0.01 || np == 8);
    printf("cluster: %d parts automatically\n", np);
    mdl__graph_fini(&g);
    free(part);
    free(X);
    mdl_meshseq_destroy(s);
    mdl_rig_destroy(rig);
    printf("cluster: ok\n");
    return 0;
}
