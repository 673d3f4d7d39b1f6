/* params.h - the client side of the "params" encoding (docs/PROTOCOL.md 2b, 3): parses the params
 * model message (MSPM) a params client gets once per generation, and rebuilds a params frame's
 * vertices from it on the CPU, as the reference for the viewer's vertex shader
 * (clients/web/params.js) and for C clients:
 *   V_v = sum_s w_vs (R(q_i) (mean_e + sum_a lambda_ia scale_a mode_a[e]) + t_i)
 * (i = the slot's piece, e its entry; q_i, t_i, lambda_i from the frame).
 * The parser reads data from the network: every count is checked against the message length and
 * every index against its table before anything is read; a bad message is refused with a reason.
 * ws_params_parse allocates (ws_params_free frees) and unpacks the little-endian tables into native
 * arrays once, so that a frame's decode reads aligned values only (an unaligned read per float
 * costs a call in an unoptimised or instrumented build); ws_params_decode allocates nothing, and
 * writes the frame's floats into the layout's scratch (one decode at a time per ws_params). */
#ifndef MESHSTEER_CLIENTS_PARAMS_H
#define MESHSTEER_CLIENTS_PARAMS_H

#include <stddef.h>
#include <stdint.h>

#define WS_PARAMS_MAX_LAYOUTS 2

typedef struct ws_params_layout {
    int kind, slots, ninst, nparts, nentries, nmodes, nparams, nused;
    const unsigned char *part;   /* nparts x 16 bytes: first entry, entries, modes, first mode */
    const unsigned char *inst;   /* ninst x u32: the shape of each piece */
    const unsigned char *scale;  /* nmodes x f32 */
    const unsigned char *mean;   /* nentries x 3 f32 */
    const unsigned char *modes;  /* int16 values, part-major, mode-major, entry, xyz */
    const unsigned char *count;  /* nv x u8: slots in use per vertex (at most `slots`) */
    const unsigned char *slot;   /* nused x {u32 entry, f32 weight}, vertex by vertex */
    const unsigned char *piece;  /* nused x u16: the piece of each */
    uint32_t *slot_at;           /* nv + 1: the first slot of each vertex */
    uint32_t *mode_at;           /* nparts: the first int16 of the shape's modes */
    uint32_t *param_at;          /* ninst: the first float of the piece in a frame */
    /* the same tables unpacked (native byte order, aligned) */
    uint32_t *shape_of;          /* ninst: inst */
    uint32_t *shape_info;        /* nparts x 4: part */
    float *scale_v, *mean_v;     /* nmodes; nentries x 3 */
    int16_t *modes_v;            /* the mode values */
    uint32_t *slot_entry;        /* nused: slot's entry */
    float *slot_weight;          /* nused: slot's weight */
    uint16_t *slot_piece;        /* nused: piece */
    float *frame;                /* nparams: scratch, one frame's floats */
} ws_params_layout;

typedef struct ws_params {
    uint32_t generation;
    int nv, nlayouts;
    ws_params_layout layout[WS_PARAMS_MAX_LAYOUTS];
    unsigned char *msg;          /* a copy of the message, which the layouts point into */
} ws_params;

/* 0, or -1 with the reason in err (errlen bytes). On success *out owns a copy of buf. */
int ws_params_parse(const unsigned char *buf, size_t len, ws_params *out, char *err, size_t errlen);
void ws_params_free(ws_params *p);
/* The vertex block of a params frame (block = the frame from byte 56, len its bytes up to the
 * markers or more) into V (nv x 3). 0, or -1 with the reason (layout or size mismatch). */
int ws_params_decode(const ws_params *p, const unsigned char *block, size_t len, float *V,
                     char *err, size_t errlen);

#endif
