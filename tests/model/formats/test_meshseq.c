/* test_meshseq.c - model/meshseq.c: OBJ directories (natural order, identical faces), PC2 + rest
 * OBJ, topology fingerprints, and writing a sequence as numbered OBJ frames. */
#include "model.h"
#include "test.h"

#include <errno.h>
#include <stdint.h>
#include <unistd.h>

static void write_text(const char *dir, const char *name, const char *text)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    ASSERT(f);
    fputs(text, f);
    ASSERT(fclose(f) == 0);
}

static void remove_dir(const char *dir, const char *const *names, int n)
{
    char path[512];
    for (int i = 0; i < n; i++) {
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        unlink(path);
    }
    ASSERT(rmdir(dir) == 0);
}

static void assert_frame_is_obj(const mdl_meshseq *s, int frame, const char *path)
{
    char err[MDL_ERR_LEN] = "";
    mdl_mesh *m;
    ASSERT_OK(mdl_mesh_read_obj(path, &m, err), err);
    ASSERT_INT_EQ(m->nv, s->nv);
    ASSERT_INT_EQ(m->nf, s->nf);
    ASSERT(memcmp(m->F, s->F, (size_t)m->nf * 3 * sizeof(uint32_t)) == 0);
    const float *V = s->V + (size_t)frame * (size_t)s->nv * 3;
    for (int i = 0; i < 3 * m->nv; i++)
        ASSERT_NEAR_I(V[i], m->V[i], 0, i);
    mdl_mesh_destroy(m);
}

static void test_horse_gallop(uint64_t *fp)
{
    const char *dir = test_data("meshes/horse-gallop");
    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *s;
    ASSERT_OK(mdl_meshseq_read(dir, NULL, &s, err), err);
    ASSERT_INT_EQ(s->frames, 48);
    ASSERT_INT_EQ(s->nv, 8431);
    ASSERT_INT_EQ(s->nf, 16843);
    ASSERT(s->fps == 0);
    assert_frame_is_obj(s, 0, test_data("meshes/horse-gallop/0001.obj"));
    assert_frame_is_obj(s, 9, test_data("meshes/horse-gallop/0010.obj"));
    assert_frame_is_obj(s, 47, test_data("meshes/horse-gallop/0048.obj"));
    *fp = mdl_topology_fingerprint(s->F, s->nf, s->nv);
    mdl_meshseq_destroy(s);
}

static void test_horse_collapse(uint64_t *fp)
{
    const char *pc2 = test_data("meshes/horse-collapse/horse-collapse.pc2");
    const char *rest = test_data("meshes/horse-collapse/rest.obj");
    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *s;
    ASSERT_OK(mdl_meshseq_read(pc2, rest, &s, err), err);
    ASSERT_INT_EQ(s->frames, 53);
    ASSERT_INT_EQ(s->nv, 8431);
    ASSERT_INT_EQ(s->nf, 16843);
    assert_frame_is_obj(s, 0, rest);
    *fp = mdl_topology_fingerprint(s->F, s->nf, s->nv);
    mdl_meshseq_destroy(s);

    /* a PC2 needs its rest OBJ, with the same number of points */
    mdl_meshseq *bad = (mdl_meshseq *)1;
    ASSERT_INT_EQ(mdl_meshseq_read(pc2, NULL, &bad, err), -EINVAL);
    ASSERT(bad == NULL);
    ASSERT(strstr(err, "needs a rest OBJ"));
    ASSERT_INT_EQ(mdl_meshseq_read(pc2, test_data("meshes/samba/rest.obj"), &bad, err),
                  MDL_ETOPOLOGY);
    ASSERT(strstr(err, "8431 points, but the rest mesh"));
    ASSERT(strstr(err, "has 9971 vertices"));
}

static void test_fingerprint(uint64_t gallop, uint64_t collapse)
{
    /* same counts (8431, 16843), different face lists */
    ASSERT(gallop != collapse);
    const uint32_t F[] = {0, 1, 2, 0, 2, 3};
    const uint32_t G[] = {0, 1, 2, 0, 3, 2};
    uint64_t a = mdl_topology_fingerprint(F, 2, 4);
    ASSERT(a == mdl_topology_fingerprint(F, 2, 4));
    ASSERT(a != mdl_topology_fingerprint(G, 2, 4));
    ASSERT(a != mdl_topology_fingerprint(F, 2, 5)); /* an extra unused vertex */
    ASSERT(a != mdl_topology_fingerprint(F, 1, 4));
    /* FNV-1a 64 of the 8 bytes 00 00 00 00 00 00 00 00 (nv = nf = 0) */
    uint64_t h = 0xcbf29ce484222325ull;
    for (int i = 0; i < 8; i++)
        h = (h ^ 0) * 0x100000001b3ull;
    ASSERT(mdl_topology_fingerprint(NULL, 0, 0) == h);
}

static const char *tri = "v %d 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n";

static void test_natural_order(void)
{
    char dir[] = "/tmp/test_meshseq_XXXXXX";
    ASSERT(mkdtemp(dir));
    /* the frame number is the x of vertex 0; 10.obj must come after 2.obj */
    const char *names[] = {"10.obj", "2.obj", "1.obj", "notes.txt", "frame.obj.bak", "11.OBJ"};
    const int value[] = {10, 2, 1, 0, 0, 11};
    for (int i = 0; i < 6; i++) {
        char text[128];
        snprintf(text, sizeof text, tri, value[i]);
        write_text(dir, names[i], i == 3 ? "not a mesh\n" : text);
    }
    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *s;
    ASSERT_OK(mdl_meshseq_read(dir, NULL, &s, err), err);
    ASSERT_INT_EQ(s->frames, 4);
    const int want[] = {1, 2, 10, 11};
    for (int f = 0; f < 4; f++)
        ASSERT_NEAR_I(s->V[(size_t)f * 9], want[f], 0, f);
    mdl_meshseq_destroy(s);
    remove_dir(dir, names, 6);

    /* zero-padded names and names with a prefix sort the same way */
    char dir2[] = "/tmp/test_meshseq_XXXXXX";
    ASSERT(mkdtemp(dir2));
    const char *padded[] = {"mesh_0010.obj", "mesh_0009.obj", "mesh_0100.obj", "mesh_0000.obj"};
    const int pv[] = {10, 9, 100, 0};
    for (int i = 0; i < 4; i++) {
        char text[128];
        snprintf(text, sizeof text, tri, pv[i]);
        write_text(dir2, padded[i], text);
    }
    ASSERT_OK(mdl_meshseq_read(dir2, NULL, &s, err), err);
    ASSERT_INT_EQ(s->frames, 4);
    const int want2[] = {0, 9, 10, 100};
    for (int f = 0; f < 4; f++)
        ASSERT_NEAR_I(s->V[(size_t)f * 9], want2[f], 0, f);
    mdl_meshseq_destroy(s);
    remove_dir(dir2, padded, 4);
}

static void test_errors(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *s = (mdl_meshseq *)1;

    /* different faces in the third file: the message names that file and the first frame */
    char dir[] = "/tmp/test_meshseq_XXXXXX";
    ASSERT(mkdtemp(dir));
    const char *names[] = {"1.obj", "2.obj", "3.obj"};
    write_text(dir, "1.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\n");
    write_text(dir, "2.obj", "v 0 0 0\nv 2 0 0\nv 0 2 0\nv 0 0 2\nf 1 2 3\nf 1 3 4\n");
    write_text(dir, "3.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 4 3\n");
    ASSERT_INT_EQ(mdl_meshseq_read(dir, NULL, &s, err), MDL_ETOPOLOGY);
    ASSERT(s == NULL);
    ASSERT(strstr(err, "/3.obj: faces differ from "));
    ASSERT(strstr(err, "/1.obj (first difference at triangle 1"));

    /* a different vertex count */
    write_text(dir, "3.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 3 2\n");
    ASSERT_INT_EQ(mdl_meshseq_read(dir, NULL, &s, err), MDL_ETOPOLOGY);
    ASSERT(strstr(err, "/3.obj: 3 vertices, but "));

    /* a broken frame: the OBJ reader's message with file and line */
    write_text(dir, "2.obj", "v 0 0 0\nv 1 0 0\nv 0 1 oops\n");
    ASSERT_INT_EQ(mdl_meshseq_read(dir, NULL, &s, err), MDL_EFORMAT);
    ASSERT(strstr(err, "/2.obj:3: bad number \"oops\""));
    remove_dir(dir, names, 3);

    /* no OBJ files at all */
    char empty[] = "/tmp/test_meshseq_XXXXXX";
    ASSERT(mkdtemp(empty));
    write_text(empty, "readme.txt", "hello\n");
    const char *rn[] = {"readme.txt"};
    ASSERT_INT_EQ(mdl_meshseq_read(empty, NULL, &s, err), -ENOENT);
    ASSERT(strstr(err, "no .obj files"));
    remove_dir(empty, rn, 1);

    ASSERT_INT_EQ(mdl_meshseq_read("/nonexistent/seq", NULL, &s, err), -ENOENT);
    ASSERT(strstr(err, "/nonexistent/seq"));
    mdl_meshseq_destroy(NULL);
}

static void test_write_objdir(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_meshseq *s;
    ASSERT_OK(mdl_meshseq_read(test_data("meshes/horse-collapse/horse-collapse.pc2"),
                               test_data("meshes/horse-collapse/rest.obj"), &s, err),
              err);
    /* write the first 12 frames (so that 0010.obj and 0011.obj exist) into a new directory */
    char base[] = "/tmp/test_meshseq_XXXXXX";
    ASSERT(mkdtemp(base));
    char dir[128];
    snprintf(dir, sizeof dir, "%s/out", base);
    mdl_meshseq part = *s;
    part.frames = 12;
    ASSERT_OK(mdl_meshseq_write_objdir(dir, &part, err), err);
    ASSERT_OK(mdl_meshseq_write_objdir(dir, &part, err), err); /* an existing directory is fine */
    mdl_meshseq *r;
    ASSERT_OK(mdl_meshseq_read(dir, NULL, &r, err), err);
    ASSERT_INT_EQ(r->frames, 12);
    ASSERT_INT_EQ(r->nv, s->nv);
    ASSERT_INT_EQ(r->nf, s->nf);
    ASSERT(memcmp(r->F, s->F, (size_t)s->nf * 3 * sizeof(uint32_t)) == 0);
    ASSERT(memcmp(r->V, s->V, (size_t)12 * s->nv * 3 * sizeof(float)) == 0);
    mdl_meshseq_destroy(r);

    /* a file where the directory should be */
    char file[160];
    snprintf(file, sizeof file, "%s/0000.obj", dir);
    ASSERT(mdl_meshseq_write_objdir(file, &part, err) < 0);
    ASSERT(strstr(err, "0000.obj: cannot create directory"));

    const char *names[12];
    char nb[12][16];
    for (int i = 0; i < 12; i++) {
        snprintf(nb[i], sizeof nb[i], "%04d.obj", i);
        names[i] = nb[i];
    }
    remove_dir(dir, names, 12);
    ASSERT(rmdir(base) == 0);
    mdl_meshseq_destroy(s);
}

int main(void)
{
    test_natural_order();
    test_errors();
    uint64_t gallop, collapse;
    test_horse_gallop(&gallop);
    test_horse_collapse(&collapse);
    test_fingerprint(gallop, collapse);
    test_write_objdir();
    return 0;
}
