/* fuzz_labels.c - fuzz target for the label map parser (server/labels.c, --labels), and binding
 * the parsed map to a small model marker set and source label set. */
#include "labels.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static void ignore(void *ud, const char *msg)
{
    (void)ud;
    (void)msg;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char *text = malloc(size + 1);
    if (!text)
        return 0;
    memcpy(text, data, size);
    text[size] = '\0';
    srv_labels *l = NULL;
    char err[MDL_ERR_LEN];
    if (srv_labels_create(text, &l, err) == 0) {
        static const mdl_rig_marker mk[] = {
            {"withers", "Neck", 0}, {"croup", "Hips", 1}, {"lf_hoof", "lhand", 2},
            {"head", "Head_End", 3}};
        mdl_model_info info;
        memset(&info, 0, sizeof info);
        info.nmarkers = 4;
        info.markers = mk;
        static const char *names[] = {"head", "lhand", "rhand", "lfoot", "rfoot", "torso"};
        int map[4];
        srv_labels_bind(l, &info, names, 6, map, ignore, NULL);
        for (int i = 0; i < srv_labels_count(l); i++)
            if (!srv_labels_model(l, i)[0] || !srv_labels_live(l, i)[0] ||
                strlen(srv_labels_model(l, i)) >= MDL_NAME_LEN)
                abort(); /* the parser promised non-empty, bounded names */
    }
    srv_labels_destroy(l);
    free(text);
    return 0;
}
