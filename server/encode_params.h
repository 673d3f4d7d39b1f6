/* encode_params.h - the "params" encoding of the /stream protocol (docs/PROTOCOL.md, sections 2b
 * and 3): the compact form of a synthesis (model.h, mdl_params_layout) as the params model message
 * ("MSPM", sent once per generation to a client that chose params) and the per-frame parameter
 * block of a frame with encoding 2.
 *
 * MSPM holds one layout per kind of the generation that has a compact form (the primary kind, and
 * the idle kind when there is one); a params frame names its layout. Quantisation: the mode
 * vectors are int16 with one scale per mode (scale = max |component| / 32767, so a component is
 * off by at most scale / 2); means, weights and the per-frame parameters are float32. The
 * reconstruction error is then at most sum_a |lambda_a| scale_a / 2 * sqrt(3) per vertex beyond
 * float rounding (test_encode measures it against the int16 bound). Nothing here allocates. */
#ifndef MESHSTEER_SERVER_ENCODE_PARAMS_H
#define MESHSTEER_SERVER_ENCODE_PARAMS_H

#include "model.h"

#include <stddef.h>

#define SRV_PARAMS_MAGIC "MSPM"
#define SRV_PARAMS_HEADER 16
#define SRV_PARAMS_LAYOUT_HEADER 36
#define SRV_PARAMS_MAX_LAYOUTS 2

/* Checks that a layout's indices lie in range and its counts fit the wire's fields; 0 or -EINVAL
 * with the reason in err (SRV_ERR_LEN). */
int srv_params_layout_check(const mdl_params_layout *L, int nv, char *err);
/* The MSPM message's length for these layouts. */
size_t srv_params_model_size(const mdl_params_layout *L, int nlayouts, int nv);
/* Writes it into p (srv_params_model_size bytes). */
void srv_params_model_write(unsigned char *p, const mdl_params_layout *L, int nlayouts, int nv,
                            uint32_t generation);
/* The vertex block of a params frame: 8 + 4 nparams bytes. */
size_t srv_params_block_size(int nparams);
/* Writes layout index and nparams floats at p (srv_params_block_size bytes). */
void srv_params_block_write(unsigned char *p, int layout, const float *prm, int nparams);

#endif
