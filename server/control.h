/* control.h - the client -> server control messages of /stream (docs/PROTOCOL.md, "Control").
 *
 * A control message is one JSON object in a text frame: {"type": T, ...fields, "id": optional}.
 *   {"type":"encoding","encoding":"float32"|"int16"}
 *   {"type":"pause"}   {"type":"resume"}
 *   {"type":"seek","frame":N}          N a whole number >= 0
 *   {"type":"speed","speed":S}         a number (the source takes 0.001 <= S <= 100)
 *   {"type":"ping"}                    answered by {"type":"pong","server_us":T}
 * "id" (a number, or a string of at most 64 bytes) is echoed in the reply. Every field is checked;
 * unknown types and fields are errors. Replies: {"type":"ack","request":T[,"id"]},
 * {"type":"error","code":C,"message":M[,"request":T][,"id"]}. Parsing allocates only inside cJSON
 * and never fails the connection. */
#ifndef MESHSTEER_SERVER_CONTROL_H
#define MESHSTEER_SERVER_CONTROL_H

#include <stddef.h>
#include <stdint.h>

enum {
    SRV_CTL_ENCODING = 1,
    SRV_CTL_PAUSE,
    SRV_CTL_RESUME,
    SRV_CTL_SEEK,
    SRV_CTL_SPEED,
    SRV_CTL_PING,
};

/* A set of control kinds, e.g. what a source accepts: SRV_CTL_BIT(SRV_CTL_PAUSE) | ... */
#define SRV_CTL_BIT(kind) (1u << (kind))

#define SRV_CTL_ID_LEN 80   /* the id, as JSON text */
#define SRV_REPLY_LEN 1024  /* every reply fits */

typedef struct srv_control {
    int kind;               /* SRV_CTL_* */
    const char *type;       /* static name of the kind */
    int encoding;           /* SRV_ENC_* for SRV_CTL_ENCODING */
    double value;           /* frame for SEEK, factor for SPEED */
    char id[SRV_CTL_ID_LEN]; /* "" when absent, else JSON text (42 or "abc") */
} srv_control;

/* Returns 0, or -1 with *code set to a static error code ("malformed", "unknown_type",
 * "bad_field") and msg (msglen bytes) to a sentence. out->type and out->id are filled as far as
 * the message allows, so an error reply can still name the request. */
int srv_control_parse(const char *txt, size_t len, srv_control *out, const char **code, char *msg,
                      size_t msglen);

/* Copies src into dst (n > 0 bytes, NUL-terminated) as valid UTF-8: an invalid byte becomes '?',
 * and a cut falls between characters, never inside one (a text frame that is not UTF-8 fails the
 * connection: RFC 6455 Sec. 8.1). Returns the bytes written. */
size_t srv__utf8_copy(char *dst, size_t n, const char *src);
/* 1 when the n bytes at s are valid UTF-8 (RFC 3629: no overlong forms, no surrogates, at most
 * U+10FFFF). */
int srv__utf8_valid(const char *s, size_t n);

/* The static name of a kind ("pause", ...), or NULL. */
const char *srv_control_name(int kind);

/* The source controls in the order the hello lists them (pause, resume, seek, speed). */
#define SRV_SOURCE_CONTROLS 4
extern const int srv_source_controls[SRV_SOURCE_CONTROLS];
/* The names of the SRV_CTL_BIT()s in `bits`, in that order, comma separated ("" for none). */
void srv_controls_text(unsigned bits, char *buf, size_t len);

/* Reply texts into buf (SRV_REPLY_LEN); return the length. An ack of a source control carries
 * seq >= 0, the newest frame made before the control took effect (a negative seq: none). */
size_t srv_reply_ack(char *buf, const srv_control *c, int64_t seq);
size_t srv_reply_pong(char *buf, const srv_control *c, uint64_t server_us);
size_t srv_reply_error(char *buf, const char *code, const char *message, const srv_control *c);

#endif
