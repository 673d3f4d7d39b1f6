/* wsframe.h - the receiving half of a WebSocket client (RFC 6455 Sec. 4.1 and 5), for the load
 * client: the server's handshake response, then its frames as a byte stream.
 *
 * ws_handshake_end() finds the end of the 101 response headers. ws_rx_feed() takes the stream in
 * pieces of any size (one recv each) and calls back once per complete message with its first
 * `keep` bytes and its total length, and once per control frame (ping, pong, close) with its
 * payload. It copies only what it keeps: payload beyond that is skipped in bulk, which is what
 * makes it cheap next to libwebsockets 4.1's client (docs/PERFORMANCE.md). Server frames must be
 * unmasked, without RSV bits (no extension is negotiated), control frames unfragmented and at most
 * 125 bytes; a violation stops the parser with a reason. No allocation. */
#ifndef MESHSTEER_CLIENTS_WSFRAME_H
#define MESHSTEER_CLIENTS_WSFRAME_H

#include <stddef.h>
#include <stdint.h>

#define WS_KEEP_MAX 64

enum { WS_OP_CONT = 0, WS_OP_TEXT = 1, WS_OP_BINARY = 2, WS_OP_CLOSE = 8, WS_OP_PING = 9,
       WS_OP_PONG = 10 };

typedef struct ws_rx {
    size_t keep;               /* bytes of each message to keep, <= WS_KEEP_MAX */
    unsigned char fh[14];      /* the frame header being read */
    size_t fh_len, fh_need;
    uint64_t remaining;        /* payload bytes left in the current frame */
    int opcode, fin;
    int in_msg, msg_binary;    /* a data message is in progress (fragments) */
    unsigned char head[WS_KEEP_MAX];
    size_t head_len;
    uint64_t msg_len;
    unsigned char ctl[125];    /* control frame payload */
    size_t ctl_len;
    const char *error;         /* why the parser stopped (static string) */
} ws_rx;

typedef struct ws_rx_cb {
    /* a whole data message: head = its first min(keep, len) bytes */
    void (*message)(void *ud, int binary, const unsigned char *head, size_t head_len,
                    uint64_t len);
    /* a control frame; a nonzero return stops the parser (e.g. after close) */
    int (*control)(void *ud, int opcode, const unsigned char *payload, size_t len);
    void *ud;
} ws_rx_cb;

void ws_rx_init(ws_rx *r, size_t keep);
/* Parses n more bytes. Returns 0, -1 on a protocol error (r->error says which), or the control
 * callback's nonzero value. After a nonzero return the parser must not be fed again. */
int ws_rx_feed(ws_rx *r, const unsigned char *p, size_t n, const ws_rx_cb *cb);

/* The handshake response in buf[0..len): the length of its headers (up to and including the
 * blank line) when they are complete and the status is 101, 0 when more bytes are needed, -1 when
 * the server refused (any other status, or no HTTP/1.1 status line). */
long ws_handshake_end(const char *buf, size_t len);

#endif
