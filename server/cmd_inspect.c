/* cmd_inspect.c - `meshsteer inspect MODEL`: a human-readable summary of a model file. */
#include "cli.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int cmd_inspect(int argc, char **argv)
{
    if (argc == 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        printf("usage: meshsteer inspect MODEL\n\nPrints what a model file holds: mesh, rig, parts, "
               "shape modes, limbs and their regressions.\n");
        return CLI_EXIT_OK;
    }
    if (argc != 2)
        return cli_usage_error("inspect", "usage: meshsteer inspect MODEL");
    char err[MDL_ERR_LEN];
    mdl_model *m;
    if (mdl_model_load(argv[1], &m, err))
        return cli_fail("inspect", CLI_EXIT_USAGE, "%s", err);
    size_t len = 1 << 20;
    char *buf = malloc(len);
    if (!buf) {
        mdl_model_destroy(m);
        return cli_fail("inspect", CLI_EXIT_FAIL, "out of memory");
    }
    mdl_model_describe(m, buf, len);
    fputs(buf, stdout);
    free(buf);
    mdl_model_destroy(m);
    return CLI_EXIT_OK;
}
