/* test_rig.c - model/rig.c: a valid rig from tests/data and from strings, and a table of invalid
 * rigs, each with the JSON path its message must name. */
#include "model.h"
#include "test.h"

#include <errno.h>

static int parse(const char *text, int nv, mdl_rig **r, char *err)
{
    size_t n = strlen(text);
    char *b = malloc(n ? n : 1); /* exact size, no NUL: ASan catches over-reads */
    memcpy(b, text, n);
    int ret = mdl_rig_parse(b, n, "rig.json", nv, r, err);
    free(b);
    return ret;
}

static void test_file(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_rig *r;
    ASSERT_OK(mdl_rig_read(test_src("tests/data/rig_quadruped.json"), 8431, &r, err), err);
    ASSERT_INT_EQ(r->nmarkers, 7);
    ASSERT(strcmp(r->markers[0].name, "withers") == 0);
    ASSERT(strcmp(r->markers[0].source, "withers") == 0); /* source defaults to name */
    ASSERT(strcmp(r->markers[3].source, "LeftHand") == 0);
    ASSERT_INT_EQ(r->markers[3].vertex, 2080);
    ASSERT_INT_EQ(r->markers[6].vertex, 8430);
    ASSERT_INT_EQ(r->nref, 3);
    ASSERT_INT_EQ(r->ref[0], 0);
    ASSERT_INT_EQ(r->ref[1], 1);
    ASSERT_INT_EQ(r->ref[2], 2);
    ASSERT_INT_EQ(r->nlimbs, 5);
    ASSERT_INT_EQ(r->limb_off[0], 0);
    ASSERT_INT_EQ(r->limb_off[5], 10);
    ASSERT_INT_EQ(r->limb_idx[r->limb_off[3]], 1);     /* croup */
    ASSERT_INT_EQ(r->limb_idx[r->limb_off[3] + 1], 5); /* lh_hoof */
    mdl_rig_destroy(r);

    /* the same file against a smaller mesh: the last marker is out of range */
    ASSERT_INT_EQ(mdl_rig_read(test_src("tests/data/rig_quadruped.json"), 8430, &r, err),
                  MDL_EFORMAT);
    ASSERT(strstr(err, "rig_quadruped.json: markers[6].vertex: 8430 is out of range (mesh has 8430 vertices)"));
    ASSERT_INT_EQ(mdl_rig_read("/nonexistent/rig.json", 0, &r, err), -ENOENT);
    mdl_rig_destroy(NULL);
}

static void test_strings(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_rig *r;
    /* a path limb of 3 markers, a 2-marker reference, nv = 0 skips the range check */
    ASSERT_OK(parse("{\"markers\":[{\"name\":\"a\",\"vertex\":0},{\"name\":\"b\",\"vertex\":99999,"
                    "\"source\":\"B\"},{\"name\":\"c\",\"vertex\":5,\"source\":null}],"
                    "\"reference\":[\"b\",\"a\"],\"limbs\":[[\"a\",\"b\",\"c\"],[\"c\",\"a\"]]}\n",
                    0, &r, err),
              err);
    ASSERT_INT_EQ(r->nmarkers, 3);
    ASSERT_INT_EQ(r->nref, 2);
    ASSERT_INT_EQ(r->ref[0], 1);
    ASSERT_INT_EQ(r->ref[1], 0);
    ASSERT_INT_EQ(r->nlimbs, 2);
    const int off[] = {0, 3, 5}, idx[] = {0, 1, 2, 2, 0};
    for (int i = 0; i < 3; i++)
        ASSERT_NEAR_I(r->limb_off[i], off[i], 0, i);
    for (int i = 0; i < 5; i++)
        ASSERT_NEAR_I(r->limb_idx[i], idx[i], 0, i);
    ASSERT(strcmp(r->markers[1].source, "B") == 0);
    ASSERT(strcmp(r->markers[2].source, "c") == 0);
    ASSERT_INT_EQ(r->markers[1].vertex, 99999);
    mdl_rig_destroy(r);
}

#define M2 "\"markers\":[{\"name\":\"a\",\"vertex\":1},{\"name\":\"b\",\"vertex\":2}]"

static const struct {
    const char *json;
    int nv;
    const char *want;
} bad[] = {
    {"", 0, "rig.json:1:1: invalid JSON"},
    {"{\"markers\": [\n  {\"name\": \"a\",, }]}", 0, "rig.json:2:"},
    {"[1, 2]", 0, "rig.json: the top level must be a JSON object"},
    {"{" M2 ", \"reference\":[\"a\",\"b\"], \"limbs\":[[\"a\",\"b\"]]} x", 0,
     "unexpected data after the JSON value"},
    {"{\"reference\":[\"a\",\"b\"], \"limbs\":[[\"a\",\"b\"]]}", 0, "rig.json: markers: missing"},
    {"{\"markers\":{}, \"reference\":[], \"limbs\":[]}", 0, "rig.json: markers: must be an array"},
    {"{\"markers\":[{\"name\":\"a\",\"vertex\":1}]}", 0, "markers: 1 markers (need at least 2)"},
    {"{\"markers\":[{\"name\":\"a\",\"vertex\":1}, 7]}", 0, "rig.json: markers[1]: must be an object"},
    {"{\"markers\":[{\"name\":\"a\",\"vertex\":1}, {\"vertex\":2}]}", 0,
     "rig.json: markers[1].name: missing"},
    {"{\"markers\":[{\"name\":\"a\",\"vertex\":1}, {\"name\":3,\"vertex\":2}]}", 0,
     "rig.json: markers[1].name: must be a string"},
    {"{\"markers\":[{\"name\":\"\",\"vertex\":1}, {\"name\":\"b\",\"vertex\":2}]}", 0,
     "rig.json: markers[0].name: must not be empty"},
    {"{\"markers\":[{\"name\":\"a\",\"vertex\":1}, {\"name\":\"a\",\"vertex\":2}]}", 0,
     "rig.json: markers[1].name: \"a\" is used by markers[0] already"},
    {"{\"markers\":[{\"name\":\"a\",\"vertex\":1}, {\"name\":\"b\"}]}", 0,
     "rig.json: markers[1].vertex: missing"},
    {"{\"markers\":[{\"name\":\"a\",\"vertex\":\"1\"}, {\"name\":\"b\",\"vertex\":2}]}", 0,
     "rig.json: markers[0].vertex: must be a number"},
    {"{\"markers\":[{\"name\":\"a\",\"vertex\":1.5}, {\"name\":\"b\",\"vertex\":2}]}", 0,
     "rig.json: markers[0].vertex: 1.5 is not an integer"},
    {"{\"markers\":[{\"name\":\"a\",\"vertex\":-1}, {\"name\":\"b\",\"vertex\":2}]}", 0,
     "rig.json: markers[0].vertex: -1 is out of range"},
    {"{\"markers\":[{\"name\":\"a\",\"vertex\":1e300}, {\"name\":\"b\",\"vertex\":2}]}", 0,
     "rig.json: markers[0].vertex: 1e+300 is out of range"},
    {"{\"markers\":[{\"name\":\"a\",\"vertex\":1}, {\"name\":\"b\",\"vertex\":9000}]}", 8431,
     "rig.json: markers[1].vertex: 9000 is out of range (mesh has 8431 vertices)"},
    {"{\"markers\":[{\"name\":\"a\",\"vertex\":1,\"source\":false}, {\"name\":\"b\",\"vertex\":2}]}",
     0, "rig.json: markers[0].source: must be a string"},
    {"{\"markers\":[{\"name\":\"a234567890123456789012345678901234567890123456789012345678901234\","
     "\"vertex\":1}, {\"name\":\"b\",\"vertex\":2}]}",
     0, "rig.json: markers[0].name: \"a2345678901234567890...\" is 64 bytes long (at most 63)"},
    {"{" M2 "}", 0, "rig.json: reference: missing"},
    {"{" M2 ", \"reference\":\"a\"}", 0, "rig.json: reference: must be an array"},
    {"{" M2 ", \"reference\":[\"a\"]}", 0, "rig.json: reference: has 1 names (need 2 or 3)"},
    {"{" M2 ", \"reference\":[\"a\",\"b\",\"a\",\"b\"]}", 0, "reference: has 4 names"},
    {"{" M2 ", \"reference\":[\"a\",\"x\"]}", 0, "rig.json: reference[1]: \"x\" is not a marker name"},
    {"{" M2 ", \"reference\":[\"a\",2]}", 0, "rig.json: reference[1]: must be a string"},
    {"{" M2 ", \"reference\":[\"a\",\"a\"]}", 0, "rig.json: reference[1]: \"a\" is already reference[0]"},
    {"{" M2 ", \"reference\":[\"a\",\"b\"]}", 0, "rig.json: limbs: missing"},
    {"{" M2 ", \"reference\":[\"a\",\"b\"], \"limbs\":{}}", 0, "rig.json: limbs: must be an array"},
    {"{" M2 ", \"reference\":[\"a\",\"b\"], \"limbs\":[]}", 0, "rig.json: limbs: empty"},
    {"{" M2 ", \"reference\":[\"a\",\"b\"], \"limbs\":[[\"a\",\"b\"],\"a\"]}", 0,
     "rig.json: limbs[1]: must be an array of marker names"},
    {"{" M2 ", \"reference\":[\"a\",\"b\"], \"limbs\":[[\"a\",\"b\"],[\"a\"]]}", 0,
     "rig.json: limbs[1]: has 1 markers (need at least 2)"},
    {"{" M2 ", \"reference\":[\"a\",\"b\"], \"limbs\":[[\"a\",\"b\"],[\"b\",\"zz\"]]}", 0,
     "rig.json: limbs[1][1]: \"zz\" is not a marker name"},
    {"{" M2 ", \"reference\":[\"a\",\"b\"], \"limbs\":[[\"a\",\"b\",\"a\"]]}", 0,
     "rig.json: limbs[0][2]: \"a\" appears twice in this limb"},
};

static void test_invalid(void)
{
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        char err[MDL_ERR_LEN] = "";
        mdl_rig *r = (mdl_rig *)1;
        int ret = parse(bad[i].json, bad[i].nv, &r, err);
        if (ret != MDL_EFORMAT || r != NULL || !strstr(err, bad[i].want)) {
            fprintf(stderr, "case %zu: %s\nreturned %d, err \"%s\", expected \"%s\"\n", i,
                    bad[i].json, ret, err, bad[i].want);
            exit(1);
        }
    }
}

int main(void)
{
    test_strings();
    test_invalid();
    test_file();
    return 0;
}
