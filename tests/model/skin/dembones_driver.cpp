/* dembones_driver.cpp - runs Electronic Arts' Dem Bones (v1.2.1, BSD-3-Clause; not part of this
 * repository) on one of our mesh sequences, for bench_skin's side-by-side figures (issue 10).
 *
 * Dem Bones' own command-line program reads only FBX + Alembic (Autodesk's FBX SDK), so this
 * driver replaces just its input: the sequence is read with our reader (mdl_meshseq_read: a folder
 * of OBJ files, or a .pc2 with its rest OBJ), and the solver is set up exactly as Dem Bones'
 * src/command/mainCmd.cpp does when no option is given, with an init FBX that has no joints and no
 * key frames (so init() clusters the bones, as our skin does):
 *   class DemBonesExt<double, float> (solver in double, mesh sequence in float);
 *   nIters 100, and a cbIterEnd that stops when the RMSE falls by less than tolerance (1e-3)
 *   relatively in patience (3) consecutive iterations (MyDemBones in mainCmd.cpp);
 *   nInitIters 10, nTransIters 5, transAffine 10, transAffineNorm 4, bindUpdate 0,
 *   nWeightsIters 3, weightsSmooth 1e-4, weightsSmoothStep 1, weightEps 1e-15 (DemBones.h and
 *   DemBonesExt.h constructors; the program passes them through unchanged);
 *   nnz 8 unless --max-influences says (issue 10's setting is 4: `-z 4`);
 *   the rest pose u = the rest OBJ (for .pc2) or the first frame (OBJ folder), as `meshsteer skin`;
 *   fv = our triangles (the FBX reader would give the polygons; only the smoothness Laplacian uses
 *   them, and horse-gallop, samba, pcow and pjump are all triangle meshes).
 * Dem Bones then writes an FBX (computeRTB); that output step is not timed or done here.
 *
 * Prints one JSON object in the shape of `meshsteer skin --json`: bones (what Dem Bones ended
 * with: its init may give fewer), max_influences, frames, vertices, rmse (DemBones::rmse()),
 * rmse_over_diag (diagonal of the rest pose's bounding box), max_err, seconds (wall time of init()
 * plus compute(), file reading excluded, as ours), threads, iterations, diag; and init_seconds,
 * cpu_seconds.
 *
 * Our code, MIT like the rest of meshsteer; it includes Dem Bones' headers, which are not here. */
#include <DemBones/DemBonesExt.h>
#include <DemBones/MatBlocks.h>
#include <omp.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <limits>
#include <string>

#include "model.h"

namespace {

class CliDemBones : public Dem::DemBonesExt<double, float> {
public:
    double tolerance = 1e-3;
    int patience = 3;
    int iterations_done = 0;

    void compute()
    {
        previous_error = -1;
        patience_left = patience;
        iterations_done = 0;
        Dem::DemBonesExt<double, float>::compute();
    }

    /* mainCmd.cpp's convergence rule, unchanged */
    bool cbIterEnd() override
    {
        iterations_done = iter + 1;
        double e = rmse();
        if (e < previous_error * (1 + weightEps) && previous_error - e < tolerance * previous_error) {
            if (--patience_left == 0)
                return true;
        } else {
            patience_left = patience;
        }
        previous_error = e;
        return false;
    }

private:
    double previous_error = -1;
    int patience_left = 3;
};

double now(clockid_t c)
{
    timespec ts;
    clock_gettime(c, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

void usage(FILE *f)
{
    fputs("usage: dembones_driver --mesh SEQ [--rest REST.obj] --bones N [--max-influences K]\n"
          "                       [--threads T] [--json]\n"
          "Runs Dem Bones (built in) with its command-line defaults on SEQ (a folder of OBJ files\n"
          "or a .pc2 with --rest) and prints bones, rmse, seconds, ... as `meshsteer skin --json`.\n",
          f);
}

int parse_int(const char *opt, const char *s, int lo, int hi)
{
    char *end = nullptr;
    long v = strtol(s, &end, 10);
    if (!*s || *end || v < lo || v > hi) {
        fprintf(stderr, "dembones_driver: %s wants an integer in [%d, %d], not '%s'\n", opt, lo, hi, s);
        exit(2);
    }
    return (int)v;
}

/* the largest per-vertex, per-frame distance between the skinned rest pose and the input */
double max_error(const CliDemBones &d)
{
    double worst = 0;
    for (int i = 0; i < d.nV; i++) {
        for (int k = 0; k < d.nF; k++) {
            Eigen::Matrix4d mki = Eigen::Matrix4d::Zero();
            for (Eigen::SparseMatrix<double>::InnerIterator it(d.w, i); it; ++it)
                mki += it.value() * d.m.blk4(k, it.row());
            Eigen::Vector3d p = mki.topLeftCorner<3, 3>() * d.u.vec3(d.subjectID(k), i) +
                                mki.topRightCorner<3, 1>();
            worst = std::max(worst, (p - d.v.vec3(k, i).cast<double>()).norm());
        }
    }
    return worst;
}

}  // namespace

int main(int argc, char **argv)
{
    const char *mesh = nullptr, *rest = nullptr;
    int bones = 0, nnz = -1, threads = 1, json = 0;
    for (int a = 1; a < argc; a++) {
        const char *o = argv[a];
        if (!strcmp(o, "--json")) {
            json = 1;
            continue;
        }
        if (!strcmp(o, "-h") || !strcmp(o, "--help")) {
            usage(stdout);
            return 0;
        }
        if (a + 1 >= argc) {
            fprintf(stderr, "dembones_driver: %s needs a value\n", o);
            usage(stderr);
            return 2;
        }
        const char *v = argv[++a];
        if (!strcmp(o, "--mesh"))
            mesh = v;
        else if (!strcmp(o, "--rest"))
            rest = v;
        else if (!strcmp(o, "--bones"))
            bones = parse_int(o, v, 1, 1000);
        else if (!strcmp(o, "--max-influences"))
            nnz = parse_int(o, v, 1, 64);
        else if (!strcmp(o, "--threads"))
            threads = parse_int(o, v, 1, 256);
        else {
            fprintf(stderr, "dembones_driver: unknown option %s\n", o);
            usage(stderr);
            return 2;
        }
    }
    if (!mesh || !bones) {
        usage(stderr);
        return 2;
    }

    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *seq = nullptr;
    if (mdl_meshseq_read(mesh, rest, &seq, err)) {
        fprintf(stderr, "dembones_driver: %s\n", err);
        return 1;
    }
    mdl_mesh *rest_mesh = nullptr;
    if (rest && mdl_mesh_read_obj(rest, &rest_mesh, err)) {
        fprintf(stderr, "dembones_driver: %s\n", err);
        mdl_meshseq_destroy(seq);
        return 1;
    }
    const float *U = rest_mesh ? rest_mesh->V : seq->V;

    CliDemBones d;
    d.nIters = 100; /* MyDemBones' constructor */
    if (nnz > 0)
        d.nnz = nnz;
    d.nV = seq->nv;
    d.nS = 1;
    d.nF = seq->frames;
    d.fStart.resize(2);
    d.fStart << 0, d.nF;
    d.subjectID = Eigen::VectorXi::Zero(d.nF);
    d.fTime.resize(d.nF);
    for (int k = 0; k < d.nF; k++)
        d.fTime(k) = seq->fps > 0 ? k / seq->fps : k;
    d.v.resize(3 * d.nF, d.nV);
    for (int k = 0; k < d.nF; k++)
        for (int i = 0; i < d.nV; i++)
            for (int c = 0; c < 3; c++)
                d.v(3 * k + c, i) = seq->V[((size_t)k * d.nV + i) * 3 + c];
    d.u.resize(3, d.nV);
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d hi = -lo;
    for (int i = 0; i < d.nV; i++)
        for (int c = 0; c < 3; c++) {
            d.u(c, i) = U[3 * i + c];
            lo(c) = std::min(lo(c), d.u(c, i));
            hi(c) = std::max(hi(c), d.u(c, i));
        }
    double diag = (hi - lo).norm();
    d.fv.resize(seq->nf);
    for (int f = 0; f < seq->nf; f++)
        d.fv[f] = {(int)seq->F[3 * f], (int)seq->F[3 * f + 1], (int)seq->F[3 * f + 2]};
    int frames = seq->frames, vertices = seq->nv;
    mdl_mesh_destroy(rest_mesh);
    mdl_meshseq_destroy(seq);

    omp_set_num_threads(threads);
    double w0 = now(CLOCK_MONOTONIC), c0 = now(CLOCK_PROCESS_CPUTIME_ID);
    d.nB = bones; /* no joints in the init file: mainCmd.cpp sets nB, nInitIters, calls init() */
    d.init();
    double init_seconds = now(CLOCK_MONOTONIC) - w0;
    d.compute();
    double seconds = now(CLOCK_MONOTONIC) - w0, cpu = now(CLOCK_PROCESS_CPUTIME_ID) - c0;

    double rmse = d.rmse(), worst = max_error(d);
    int k = std::min(d.nnz, d.nB);
    if (json)
        printf("{\"bones\":%d,\"max_influences\":%d,\"frames\":%d,\"vertices\":%d,\"rmse\":%.9g,"
               "\"rmse_over_diag\":%.9g,\"max_err\":%.9g,\"seconds\":%.6g,\"threads\":%d,"
               "\"iterations\":%d,\"diag\":%.9g,\"init_seconds\":%.6g,\"cpu_seconds\":%.6g}\n",
               d.nB, k, frames, vertices, rmse, diag > 0 ? rmse / diag : 0, worst, seconds, threads,
               d.iterations_done, diag, init_seconds, cpu);
    else
        printf("Dem Bones: %d bones (asked %d), %d influences, %d frames, %d vertices: rmse %.6f "
               "(%.4f %% of the diagonal), max %.6f, %d iterations, %.2f s wall (init %.2f), %.2f s "
               "cpu, %d thread%s\n",
               d.nB, bones, k, frames, vertices, rmse, diag > 0 ? 100 * rmse / diag : 0, worst,
               d.iterations_done, seconds, init_seconds, cpu, threads, threads > 1 ? "s" : "");
    return 0;
}
