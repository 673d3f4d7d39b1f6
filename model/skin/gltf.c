/* gltf.c - placeholder */
#include "model.h"
#include "core/util.h"
#include <errno.h>
int mdl_skin_write_gltf(const mdl_model *m, const char *path, char *err)
{
    (void)m;
    return mdl__err(err, -ENOTSUP, "%s: glTF export not built", path);
}
