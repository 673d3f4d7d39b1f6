/* encode.h - the binary messages of the /stream protocol (docs/PROTOCOL.md, protocol 1) and the
 * per-model "generation" that owns them.
 *
 * A generation is everything the daemon derives from one loaded model: the hello (JSON), the
 * topology message (rest pose, faces, parts, quantisation box), the params model message of its
 * kinds' compact forms (encode_params.h) and a small pool of frame buffers. Each frame is encoded
 * once per encoding (float32, int16, and params where the synthesis that made it has a compact
 * form) and shared by every client by
 * reference; only the lws thread writes the per-send fields (t_send, skipped) just before
 * lws_write, and the synthesis thread refills a pool entry only once nobody references it.
 * All buffers have LWS_PRE bytes of headroom and are sized at creation: encoding allocates nothing.
 *
 * int16 quantisation (per axis a, q in [-32768, 32767]):
 *   q = clamp(round((x - qmin_a) / (qmax_a - qmin_a) * 65535), 0, 65535) - 32768
 *   x' = qmin_a + (q + 32768) * (qmax_a - qmin_a) / 65535
 * so |x - x'| <= (qmax_a - qmin_a) / 131070 for x inside the box (plus float32 rounding of the
 * decode, < 1e-6 relative). The box is the model's training bounding box grown on every side by
 * SRV_QBOX_MARGIN times its largest extent; vertices outside are clamped and the frame says so
 * (SRV_FLAG_CLAMPED). */
#ifndef MESHSTEER_SERVER_ENCODE_H
#define MESHSTEER_SERVER_ENCODE_H

#include "model.h"

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#define SRV_PROTOCOL 1
#define SRV_POOL 4
#define SRV_QBOX_MARGIN 0.5f

/* frame encodings (byte 4 of a frame); params frames exist only for kinds with a compact form
 * (encode_params.h): a client that chose params gets int16 frames from the others */
enum { SRV_ENC_FLOAT32 = 0, SRV_ENC_INT16 = 1, SRV_ENC_PARAMS = 2, SRV_ENC_COUNT = 3 };

/* frame flags (byte 5) */
enum {
    SRV_FLAG_REFERENCE_LOST = 1, /* the reference edge was missing; the last body frame was kept */
    SRV_FLAG_CLAMPED = 2,        /* int16: some vertices lay outside the box and were clamped */
    SRV_FLAG_HELD = 4,           /* some markers were missing and replaced by their last position */
    SRV_FLAG_IDLE = 8,           /* no one is tracked: the model's idle animation made this frame */
};

/* topology message ("MSTO"), little-endian */
#define SRV_TOPO_MAGIC "MSTO"
#define SRV_TOPO_HEADER 56
/* frame message ("MSFR"), little-endian */
#define SRV_FRAME_MAGIC "MSFR"
#define SRV_FRAME_HEADER 56
#define SRV_FRAME_OFF_ENCODING 4
#define SRV_FRAME_OFF_FLAGS 5
#define SRV_FRAME_OFF_MISSING 6
#define SRV_FRAME_OFF_GENERATION 8
#define SRV_FRAME_OFF_NV 12
#define SRV_FRAME_OFF_NM 16
#define SRV_FRAME_OFF_SKIPPED 20
#define SRV_FRAME_OFF_SEQ 24
#define SRV_FRAME_OFF_CAPTURE 32
#define SRV_FRAME_OFF_SYNTH 40
#define SRV_FRAME_OFF_SEND 48

typedef struct srv_gen srv_gen;

typedef struct srv_frame {
    atomic_int refs;
    srv_gen *gen;
    uint64_t seq;
    uint64_t t_capture_us;
    unsigned char *msg[SRV_ENC_COUNT]; /* message start; LWS_PRE writable bytes precede it */
    size_t len[SRV_ENC_COUNT];         /* len[SRV_ENC_PARAMS] 0: this frame has no params form
                                          (send the int16 message instead) */
} srv_frame;

/* What the hello says about the source. */
typedef struct srv_source_desc {
    const char *spec;
    const char *scheme;
    double fps;
    int frames;                /* frames of a recording (hello source.frames), 0 live */
    int count;                 /* source markers */
    const char *const *names;  /* count labels */
    unsigned controls;         /* SRV_CTL_BIT()s of the source controls accepted (pause, resume,
                                  seek, speed), listed in the hello's source.controls */
    const char *const *lookup; /* nm: the live label each model marker looks up (after the label
                                  map), for the hello's markers[].live; NULL: its own label */
    const uint8_t *bound;      /* nm: 1 when the model marker is bound to a source marker (the
                                  hello's markers[].bound); NULL: none is */
    int idle;                  /* an idle bundle is ready for when no one is tracked */
} srv_source_desc;

struct srv_gen {
    atomic_int refs;
    uint32_t id;
    char name[MDL_NAME_LEN * 2];
    char kind[16];    /* the model's primary kind (mdl_kind_name) */
    int nv, nf, nm, nparts;
    uint64_t topology;
    float qmin[3], qmax[3];
    unsigned char *hello; /* text, LWS_PRE headroom */
    size_t hello_len;
    unsigned char *topo;  /* binary, LWS_PRE headroom */
    size_t topo_len;
    int nlayouts;         /* compact forms (encode_params.h), 0 .. SRV_PARAMS_MAX_LAYOUTS */
    int layout_kind[2];   /* MDL_KIND_* of each */
    int layout_nparams[2];/* floats per frame of each */
    unsigned char *params; /* the MSPM message, LWS_PRE headroom (always: 0 layouts says none) */
    size_t params_len;
    srv_frame frames[SRV_POOL];
    unsigned char *storage;
};

/* "float32" | "int16" -> SRV_ENC_*, -1 otherwise. */
int srv_encoding_parse(const char *name);
const char *srv_encoding_name(int enc);
/* float32 and int16 frames; a params frame is srv_frame_params_size. */
size_t srv_frame_size(int enc, int nv, int nm);
size_t srv_frame_params_size(int nparams, int nm);
size_t srv_topology_size(int nv, int nf);

/* Builds a generation from the model's info (a plain struct, so tests can pass a hand-made one);
 * the generation copies what it needs and keeps neither the model nor the source description.
 * refs starts at 1; the last srv_gen_unref frees it. */
int srv_gen_create(const mdl_model_info *info, const srv_source_desc *src, uint32_t id,
                   srv_gen **out, char *err);
/* The same with the compact forms of the generation's kinds (layouts[0 .. nlayouts), at most
 * SRV_PARAMS_MAX_LAYOUTS; the primary kind's first), for the params encoding. */
int srv_gen_create_params(const mdl_model_info *info, const srv_source_desc *src, uint32_t id,
                          const mdl_params_layout *layouts, int nlayouts, srv_gen **out,
                          char *err);
void srv_gen_ref(srv_gen *g);
void srv_gen_unref(srv_gen *g); /* NULL is fine */

/* A pool frame nobody references (synthesis thread only), or NULL if all are busy. */
srv_frame *srv_gen_free_frame(srv_gen *g);
/* Encodes V (nv x 3) and the model-ordered markers (nm x 3, valid nm) into both encodings. */
void srv_frame_encode(srv_frame *f, uint64_t seq, uint64_t t_capture_us, uint64_t t_synth_us,
                      const float *V, const float *markers, const uint8_t *valid, int flags,
                      int missing);
/* After srv_frame_encode: the params message of the same frame from layout `layout`'s
 * parameters (g->layout_nparams[layout] floats, mdl_synth_params). Without this call the frame
 * has no params form. */
void srv_frame_encode_params(srv_frame *f, int layout, const float *prm);
/* A frame reference also holds its generation. */
void srv_frame_ref(srv_frame *f);
void srv_frame_unref(srv_frame *f); /* NULL is fine */

/* Little-endian stores and loads. */
static inline void srv_put_u16(unsigned char *p, uint16_t v) { p[0] = (unsigned char)v; p[1] = (unsigned char)(v >> 8); }
static inline void srv_put_u32(unsigned char *p, uint32_t v) { for (int i = 0; i < 4; i++) p[i] = (unsigned char)(v >> (8 * i)); }
static inline void srv_put_u64(unsigned char *p, uint64_t v) { for (int i = 0; i < 8; i++) p[i] = (unsigned char)(v >> (8 * i)); }
static inline uint16_t srv_get_u16(const unsigned char *p) { return (uint16_t)(p[0] | p[1] << 8); }
static inline uint32_t srv_get_u32(const unsigned char *p) { uint32_t v = 0; for (int i = 3; i >= 0; i--) v = v << 8 | p[i]; return v; }
static inline uint64_t srv_get_u64(const unsigned char *p) { uint64_t v = 0; for (int i = 7; i >= 0; i--) v = v << 8 | p[i]; return v; }

#endif
