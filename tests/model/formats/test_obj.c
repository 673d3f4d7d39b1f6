/* test_obj.c - model/obj.c: the horse OBJ against its own text, fan triangulation, every corner
 * form, corrupt inputs with their line numbers, and a write/read round trip. */
#include "model.h"
#include "test.h"

#include <errno.h>
#include <stdint.h>
#include <time.h>
#include <unistd.h>

/* Parses from an exactly sized heap copy (no NUL after it), so ASan sees any over-read. */
static int parse(const char *text, mdl_mesh **m, char *err)
{
    size_t n = strlen(text);
    char *b = malloc(n ? n : 1);
    memcpy(b, text, n);
    int r = mdl_mesh_parse_obj(b, n, "t.obj", m, err);
    free(b);
    return r;
}

static void expect_error(const char *text, const char *want)
{
    mdl_mesh *m = (mdl_mesh *)1;
    char err[MDL_ERR_LEN] = "";
    int r = parse(text, &m, err);
    if (r == 0 || m != NULL || !strstr(err, want)) {
        fprintf(stderr, "input:\n%s\nreturned %d, err \"%s\", expected an error containing \"%s\"\n",
                text, r, err, want);
        exit(1);
    }
}

static void test_horse(void)
{
    const char *path = test_data("meshes/horse-gallop/0001.obj");
    char err[MDL_ERR_LEN] = "";
    mdl_mesh *m;
    ASSERT_OK(mdl_mesh_read_obj(path, &m, err), err);
    ASSERT_INT_EQ(m->nv, 8431);
    ASSERT_INT_EQ(m->nf, 16843);

    /* the first and last `v` lines and the first `f` line, read straight from the text */
    FILE *f = fopen(path, "r");
    ASSERT(f);
    char line[512], first_v[512] = "", last_v[512] = "", first_f[512] = "";
    while (fgets(line, sizeof line, f)) {
        if (line[0] == 'v' && line[1] == ' ') {
            if (!first_v[0])
                strcpy(first_v, line);
            strcpy(last_v, line);
        } else if (line[0] == 'f' && line[1] == ' ' && !first_f[0]) {
            strcpy(first_f, line);
        }
    }
    fclose(f);
    double x, y, z;
    ASSERT_INT_EQ(sscanf(first_v, "v %lf %lf %lf", &x, &y, &z), 3);
    ASSERT(m->V[0] == (float)x && m->V[1] == (float)y && m->V[2] == (float)z);
    ASSERT_NEAR(m->V[0], -0.0227390159, 1e-9); /* 0001.obj line 1 */
    ASSERT_NEAR(m->V[1], 0.9790707, 1e-7);
    ASSERT_NEAR(m->V[2], -0.636148499, 1e-7);
    ASSERT_INT_EQ(sscanf(last_v, "v %lf %lf %lf", &x, &y, &z), 3);
    const float *lv = m->V + 3 * (m->nv - 1);
    ASSERT(lv[0] == (float)x && lv[1] == (float)y && lv[2] == (float)z);
    unsigned a, b, c;
    ASSERT_INT_EQ(sscanf(first_f, "f %u %u %u", &a, &b, &c), 3);
    ASSERT_INT_EQ(m->F[0], a - 1);
    ASSERT_INT_EQ(m->F[1], b - 1);
    ASSERT_INT_EQ(m->F[2], c - 1);
    for (int i = 0; i < 3 * m->nf; i++)
        ASSERT(m->F[i] < (uint32_t)m->nv);
    mdl_mesh_destroy(m);
}

/* all 48 frames, timed (printed, not asserted: machines are shared; see the report) */
static void test_horse_all_frames(void)
{
    test_data("meshes/horse-gallop/0048.obj");
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    long total_v = 0;
    for (int i = 1; i <= 48; i++) {
        char rel[64], err[MDL_ERR_LEN] = "";
        snprintf(rel, sizeof rel, "meshes/horse-gallop/%04d.obj", i);
        mdl_mesh *m;
        ASSERT_OK(mdl_mesh_read_obj(test_data(rel), &m, err), err);
        ASSERT_INT_EQ(m->nv, 8431);
        ASSERT_INT_EQ(m->nf, 16843);
        total_v += m->nv;
        mdl_mesh_destroy(m);
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double s = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    printf("48 horse-gallop frames (%ld vertices) read in %.3f s\n", total_v, s);
}

static void test_polygons(void)
{
    const char *text = "# a comment\r\n"
                       "o thing\n"
                       "v 0 0 0\n"
                       "v 1 0 0 1.0\n"         /* w is ignored */
                       "v 1 1 0 0.5 0.5 0.5\n" /* so are vertex colours */
                       "v 0 1 0\n"
                       "v\t0.5\t2\t0   # trailing comment\r\n"
                       "vt 0 0\nvn 0 0 1\ns off\nusemtl x\n"
                       "f 1 2 3 4\n"            /* quad -> 2 triangles */
                       "f 1/1 2/1/1 3//1 4/1 5\n"  /* pentagon, mixed corner forms -> 3 */
                       "f -5 -4 -3\n"           /* relative: 1 2 3 */
                       "\n"
                       "f 5 4 3";               /* no final newline */
    char err[MDL_ERR_LEN] = "";
    mdl_mesh *m;
    ASSERT_OK(parse(text, &m, err), err);
    ASSERT_INT_EQ(m->nv, 5);
    ASSERT_INT_EQ(m->nf, 7);
    static const uint32_t want[7][3] = {{0, 1, 2}, {0, 2, 3}, {0, 1, 2}, {0, 2, 3}, {0, 3, 4},
                                        {0, 1, 2}, {4, 3, 2}};
    for (int t = 0; t < 7; t++)
        for (int k = 0; k < 3; k++)
            ASSERT_NEAR_I(m->F[3 * t + k], want[t][k], 0, 3 * t + k);
    ASSERT(m->V[3 * 4 + 0] == 0.5f && m->V[3 * 4 + 1] == 2.0f && m->V[3 * 4 + 2] == 0.0f);
    mdl_mesh_destroy(m);

    /* relative indices refer to the vertices read so far, not to the whole file */
    ASSERT_OK(parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 9 9 9\nf -4 -3 -1\n", &m, err), err);
    ASSERT_INT_EQ(m->nf, 2);
    ASSERT_INT_EQ(m->F[3], 0);
    ASSERT_INT_EQ(m->F[5], 3);
    mdl_mesh_destroy(m);

    /* forward references are allowed as long as the vertex exists by the end */
    ASSERT_OK(parse("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", &m, err), err);
    ASSERT_INT_EQ(m->nf, 1);
    mdl_mesh_destroy(m);
}

static void test_corrupt(void)
{
    expect_error("v 0 0 0\nv 1 0 0\nv 0 x 0\nf 1 2 3\n", "t.obj:3: bad number \"x\"");
    expect_error("v 0 0 0\nv 1 0 0\nv 0 1e 0\nf 1 2 3\n", "t.obj:3: bad number \"1e\"");
    expect_error("v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n", "t.obj:2: vertex has only 2 coordinates");
    expect_error("v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "t.obj:1: coordinate 3 is not a finite");
    expect_error("v 0 0 1e39\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "t.obj:1: coordinate 3 is not a finite");
    expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n",
                 "t.obj:5: vertex index 4 is out of range (file has 3 vertices)");
    expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\nf 1 2 4\n",
                 "t.obj:4: vertex index 9 is out of range");
    expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", "t.obj:4: face corner 3: relative index -4");
    expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "t.obj:4: face corner 1: vertex index 0");
    expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\n\n\nf 1 2\n", "t.obj:6: face with 2 vertices");
    expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf\n", "t.obj:4: face with 0 vertices");
    expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3x\n", "t.obj:4: face corner 3: bad vertex index");
    expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/1/1/1\n", "t.obj:4: face corner 3: malformed");
    expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/\n", "t.obj:4: face corner 3: malformed");
    expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3//\n", "t.obj:4: face corner 3: malformed");
    expect_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n",
                 "t.obj:4: face corner 3: vertex index");
    expect_error("# nothing\nvt 0 0\n", "t.obj: no vertices");
    expect_error("", "t.obj: no vertices");
    expect_error("v 0 0 0\nv 1 0 0\n", "t.obj: no faces");
    char longnum[300] = "v 0 0 0.";
    memset(longnum + 8, '1', 200);
    strcpy(longnum + 208, "x\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    expect_error(longnum, "t.obj:1: bad number: coordinate 3 is 203 characters long");

    char err[MDL_ERR_LEN] = "";
    mdl_mesh *m;
    /* a long but well-formed decimal is fine */
    longnum[208] = '\n';
    ASSERT_OK(parse(longnum, &m, err), err);
    ASSERT(m->V[2] == (float)(1.0 / 9.0));
    mdl_mesh_destroy(m);
    ASSERT_INT_EQ(mdl_mesh_read_obj("/nonexistent/x.obj", &m, err), -ENOENT);
    ASSERT(strstr(err, "/nonexistent/x.obj"));
    ASSERT(m == NULL);
    mdl_mesh_destroy(NULL);
}

static void test_roundtrip(void)
{
    char dir[] = "/tmp/test_obj_XXXXXX";
    ASSERT(mkdtemp(dir));
    char path[64];
    snprintf(path, sizeof path, "%s/rt.obj", dir);
    /* awkward floats: denormal, large, negative zero, and values needing 9 digits */
    const float V[] = {1e-40f, -3.4e38f, -0.0f, 0.1f, 1.0f / 3.0f, 16777217.0f, 1.17549435e-38f,
                       -2.5f, 123456.789f};
    const uint32_t F[] = {0, 1, 2, 2, 1, 0};
    char err[MDL_ERR_LEN] = "";
    ASSERT_OK(mdl_mesh_write_obj(path, V, 3, F, 2, err), err);
    mdl_mesh *m;
    ASSERT_OK(mdl_mesh_read_obj(path, &m, err), err);
    ASSERT_INT_EQ(m->nv, 3);
    ASSERT_INT_EQ(m->nf, 2);
    ASSERT(memcmp(m->V, V, sizeof V) == 0);
    ASSERT(memcmp(m->F, F, sizeof F) == 0);
    mdl_mesh_destroy(m);

    /* out-of-range faces are refused by the writer */
    const uint32_t bad[] = {0, 1, 3};
    ASSERT_INT_EQ(mdl_mesh_write_obj(path, V, 3, bad, 1, err), -EINVAL);
    ASSERT(strstr(err, "face 0 has vertex 3"));
    ASSERT(mdl_mesh_write_obj("/nonexistent/dir/x.obj", V, 3, F, 2, err) < 0);
    unlink(path);
    rmdir(dir);
}

static uint64_t rng_state = 0x9e3779b97f4a7c15ull;
static uint64_t rng(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return rng_state;
}

/* Property: every coordinate equals (float)strtod(token), whatever path the reader takes. The
 * tokens include numbers at and next to float rounding midpoints, where double rounding matters. */
static void test_numbers_match_strtod(void)
{
    enum { N = 300000 };
    size_t cap = (size_t)N * 64 + 64, len = 0;
    char *text = malloc(cap);
    char (*tok)[56] = malloc((size_t)N * sizeof *tok);
    for (int i = 0; i < N; i++) {
        char *t = tok[i];
        uint64_t r = rng();
        float f, g;
        uint32_t u = (uint32_t)(r >> 32);
        switch (r % 6) {
        case 0: /* a random float, printed with 9 to 17 significant digits */
            memcpy(&f, &u, sizeof f);
            if (!isfinite(f))
                f = 1.5f;
            snprintf(t, 56, "%.*g", 9 + (int)(r % 9), (double)f);
            break;
        case 1: /* the exact midpoint between two neighbouring floats */
        case 2: /* ... and a hair above or below it, with 17 to 25 digits */
            u &= 0x7effffffu;
            memcpy(&f, &u, sizeof f);
            g = nextafterf(f, INFINITY);
            double mid = ((double)f + (double)g) / 2;
            if (r % 6 == 2)
                mid = nextafter(mid, (r >> 8) & 1 ? INFINITY : -INFINITY);
            snprintf(t, 56, "%.*g", r % 6 == 1 ? 40 : 17 + (int)((r >> 9) % 9), mid);
            break;
        case 3: /* plain decimals with many digits and leading zeros */
            snprintf(t, 56, "%s0.%019llu%03u", (r >> 10) & 1 ? "-" : "", (unsigned long long)(rng() % 10000000000000000000ull),
                     (unsigned)(r % 1000));
            break;
        case 4: /* integers and exponents */
            snprintf(t, 56, "%llu%s%d", (unsigned long long)(rng() >> (r % 64)), (r >> 7) & 1 ? "e" : "E",
                     (int)((r >> 20) % 60) - 40);
            break;
        default: /* short decimals as exporters write them */
            snprintf(t, 56, "%d.%0*u", (int)((r >> 12) % 2001) - 1000, 1 + (int)((r >> 30) % 7),
                     (unsigned)((r >> 40) % 1000000));
            break;
        }
        if (strlen(t) > 50)
            t[50] = 0;
        double d = strtod(t, NULL);
        if (!isfinite(d) || fabs(d) >= 3.4e38)
            strcpy(t, "0.25");
        len += (size_t)snprintf(text + len, cap - len, "v %s 0 0\n", t);
    }
    len += (size_t)snprintf(text + len, cap - len, "f 1 2 3\n");
    mdl_mesh *m;
    char err[MDL_ERR_LEN] = "";
    ASSERT_OK(mdl_mesh_parse_obj(text, len, "numbers.obj", &m, err), err);
    ASSERT_INT_EQ(m->nv, N);
    for (int i = 0; i < N; i++) {
        float want = (float)strtod(tok[i], NULL);
        if (memcmp(&m->V[3 * i], &want, sizeof want) != 0) {
            fprintf(stderr, "\"%s\": read %.9g, (float)strtod gives %.9g\n", tok[i], m->V[3 * i],
                    want);
            exit(1);
        }
    }
    mdl_mesh_destroy(m);
    free(tok);
    free(text);
}

int main(void)
{
    test_numbers_match_strtod();
    test_polygons();
    test_corrupt();
    test_roundtrip();
    test_horse();
    test_horse_all_frames();
    return 0;
}
