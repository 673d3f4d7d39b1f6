/* test_labels.c - label maps (server/labels.c): parsing good maps (blanks, one live label feeding
 * several model labels, the empty map), each parse error with its entry and column, and binding
 * rigs/horse-human.json's BVH joint labels to the depth sources' marker set through the README's
 * example map, with the warnings for entries that cannot take effect. */
#include "labels.h"
#include "test.h"

#include <errno.h>
#include <string.h>

static const char *depth[] = {"head", "lhand", "rhand", "lfoot", "rfoot", "torso"};

/* the map the README gives for rigs/horse-human.json */
static const char *horse_map = "Hips=torso, Neck=head, Head_End=head, LeftToe_End=lfoot, "
                               "RightToe_End=rfoot, LeftShoulder=lhand";

typedef struct warnings {
    int n;
    char last[512];
} warnings;

static void on_warn(void *ud, const char *msg)
{
    warnings *w = ud;
    w->n++;
    snprintf(w->last, sizeof w->last, "%s", msg);
}

static void expect_error(const char *text, int code, const char *message)
{
    srv_labels *l = (srv_labels *)1;
    char err[MDL_ERR_LEN] = "";
    int r = srv_labels_create(text, &l, err);
    if (r != code || l != NULL || !strstr(err, message)) {
        fprintf(stderr, "'%.60s': expected %d '%s', got %d '%s'\n", text, code, message, r, err);
        exit(1);
    }
    printf("error: %s\n", err);
}

static void parse_good(void)
{
    char err[MDL_ERR_LEN] = "";
    srv_labels *l;
    ASSERT_OK(srv_labels_create(" LeftHand = lhand ,RightHand=rhand,\tHips=torso,Spine=torso", &l,
                                err),
              err);
    ASSERT_INT_EQ(srv_labels_count(l), 4);
    ASSERT(!strcmp(srv_labels_model(l, 0), "LeftHand"));
    ASSERT(!strcmp(srv_labels_live(l, 0), "lhand"));
    ASSERT(!strcmp(srv_labels_model(l, 2), "Hips"));
    ASSERT(!strcmp(srv_labels_live(l, 3), "torso")); /* one live label, two model labels */
    ASSERT(!strcmp(srv_labels_lookup(l, "Spine"), "torso"));
    ASSERT(!strcmp(srv_labels_lookup(l, "Head"), "Head")); /* not in the map: its own name */
    ASSERT(!strcmp(srv_labels_lookup(NULL, "Head"), "Head"));
    srv_labels_destroy(l);

    /* the empty map (config `labels =`), and a label with a blank inside */
    ASSERT_OK(srv_labels_create("", &l, err), err);
    ASSERT_INT_EQ(srv_labels_count(l), 0);
    srv_labels_destroy(l);
    ASSERT_OK(srv_labels_create("  \t ", &l, err), err);
    ASSERT_INT_EQ(srv_labels_count(l), 0);
    srv_labels_destroy(l);
    ASSERT_OK(srv_labels_create("Left Hand=hand 1", &l, err), err);
    ASSERT(!strcmp(srv_labels_model(l, 0), "Left Hand") && !strcmp(srv_labels_live(l, 0), "hand 1"));
    srv_labels_destroy(l);
    srv_labels_destroy(NULL);
    ASSERT_INT_EQ(srv_labels_count(NULL), 0);

    /* the longest names and the longest text are accepted */
    char name[MDL_NAME_LEN], big[SRV_LABELS_MAX_LEN];
    memset(name, 'a', sizeof name - 1);
    name[sizeof name - 1] = '\0';
    snprintf(big, sizeof big, "%s=%s", name, name);
    ASSERT_OK(srv_labels_create(big, &l, err), err);
    srv_labels_destroy(l);
    int at = 0, k = 0;
    while (at + 12 < (int)sizeof big - 1)
        at += snprintf(big + at, sizeof big - (size_t)at, "%sm%04d=x", k ? "," : "", k), k++;
    memset(big + at, ' ', sizeof big - 1 - (size_t)at);
    big[sizeof big - 1] = '\0';
    ASSERT_OK(srv_labels_create(big, &l, err), err);
    ASSERT_INT_EQ(srv_labels_count(l), k);
    srv_labels_destroy(l);
}

static void parse_errors(void)
{
    expect_error("Hips=torso,Neck=head,LeftHand", -EINVAL,
                 "entry 3 'LeftHand': expected MODEL=LABEL (column 22)");
    expect_error("a=b,c==d", -EINVAL, "entry 2 'c==d': expected MODEL=LABEL (column 5)");
    expect_error("a=b,", -EINVAL, "entry 2 '': expected MODEL=LABEL (column 5)");
    expect_error(",a=b", -EINVAL, "entry 1 '': expected MODEL=LABEL (column 1)");
    expect_error("a=b,,c=d", -EINVAL, "entry 2 '': expected MODEL=LABEL");
    expect_error("a=b, =lhand", -EINVAL, "entry 2 ' =lhand': empty model label before '='");
    expect_error("Hips=  ", -EINVAL, "entry 1 'Hips=  ': empty live label after '=' (column 6)");
    expect_error("Hips=torso,Neck=head,Hips=head", -EINVAL,
                 "entry 3 'Hips=head': model label 'Hips' is already mapped by entry 1 (column 22)");
    expect_error("a=b\n,c=d", -EINVAL, "entry 1: control character 0x0a in a label (column 4)");
    char name[MDL_NAME_LEN + 1], text[2 * MDL_NAME_LEN + 16];
    memset(name, 'n', sizeof name - 1);
    name[sizeof name - 1] = '\0';
    snprintf(text, sizeof text, "a=b,%s=x", name);
    expect_error(text, -ENAMETOOLONG, "model label longer than 63 characters (column 5)");
    snprintf(text, sizeof text, "x=%s", name);
    expect_error(text, -ENAMETOOLONG, "live label longer than 63 characters (column 3)");
    static char big[SRV_LABELS_MAX_LEN + 10];
    memset(big, ' ', sizeof big - 1);
    memcpy(big, "a=b", 3);
    expect_error(big, -ENAMETOOLONG, "longer than 4095 characters");
}

static void bind(void)
{
    char err[MDL_ERR_LEN] = "";
    mdl_rig *rig;
    ASSERT_OK(mdl_rig_read(test_src("rigs/horse-human.json"), 0, &rig, err), err);
    mdl_model_info info;
    memset(&info, 0, sizeof info);
    info.nmarkers = rig->nmarkers;
    info.markers = rig->markers;
    int map[16];
    ASSERT(rig->nmarkers <= 16);
    warnings w = {0, ""};

    /* without a map only the labels the two sets share bind (lhand, rhand) */
    int missing = srv_labels_bind(NULL, &info, depth, 6, map, on_warn, &w);
    ASSERT_INT_EQ(missing, rig->nmarkers - 2);
    ASSERT_INT_EQ(w.n, 0);

    /* the README's map binds every marker */
    srv_labels *l;
    ASSERT_OK(srv_labels_create(horse_map, &l, err), err);
    ASSERT_INT_EQ(srv_labels_bind(l, &info, depth, 6, map, on_warn, &w), 0);
    ASSERT_INT_EQ(w.n, 0);
    for (int i = 0; i < rig->nmarkers; i++) {
        const char *want = srv_labels_lookup(l, rig->markers[i].source);
        ASSERT(map[i] >= 0 && map[i] < 6);
        if (strcmp(depth[map[i]], want)) {
            fprintf(stderr, "marker %s (%s) bound to %s, expected %s\n", rig->markers[i].name,
                    rig->markers[i].source, depth[map[i]], want);
            exit(1);
        }
        if (!strcmp(rig->markers[i].source, "Hips"))
            ASSERT(!strcmp(depth[map[i]], "torso"));
        if (!strcmp(rig->markers[i].source, "lhand")) /* not in the map: its own name */
            ASSERT(!strcmp(depth[map[i]], "lhand"));
    }
    srv_labels_destroy(l);

    /* an entry for a label the model lacks, and one naming a label the source lacks: warned,
     * not fatal; the second leaves its marker unbound. NULL names never match. */
    ASSERT_OK(srv_labels_create("LeftHand=lhand,Hips=pelvis,Neck=head", &l, err), err);
    const char *with_null[] = {"head", NULL, "lhand", "rhand"};
    w.n = 0;
    missing = srv_labels_bind(l, &info, with_null, 4, map, on_warn, &w);
    ASSERT_INT_EQ(missing, rig->nmarkers - 3); /* withers (Neck=head), lf_hoof, rf_hoof */
    ASSERT_INT_EQ(w.n, 2);
    ASSERT(strstr(w.last, "entry 2 'Hips=pelvis': the source has no marker 'pelvis'"));
    w.n = 0;
    srv_labels_bind(l, &info, with_null, 4, map, NULL, NULL); /* no callback: silent */
    missing = srv_labels_bind(l, &info, with_null, 4, map, on_warn, &w);
    ASSERT_INT_EQ(w.n, 2);
    srv_labels_destroy(l);
    ASSERT_OK(srv_labels_create("LeftHand=lhand", &l, err), err);
    w.n = 0;
    srv_labels_bind(l, &info, depth, 6, map, on_warn, &w);
    ASSERT_INT_EQ(w.n, 1);
    ASSERT(strstr(w.last, "entry 1 'LeftHand=lhand': no marker of the model has the label "
                          "'LeftHand'"));
    ASSERT_INT_EQ(srv_labels_bind(l, &info, depth, -1, map, NULL, NULL), -EINVAL);
    srv_labels_destroy(l);

    /* the same as mdl_model_bind_markers without a map: no marker of an empty source binds */
    ASSERT_INT_EQ(srv_labels_bind(NULL, &info, NULL, 0, map, NULL, NULL), rig->nmarkers);
    mdl_rig_destroy(rig);
}

int main(void)
{
    parse_good();
    parse_errors();
    bind();
    printf("labels: ok\n");
    return 0;
}
