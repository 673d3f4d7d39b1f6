/* wire_guard.h - what a client sends meshsteerd, checked byte by byte before libwebsockets reads
 * it: request heads (RFC 9112 Sec. 2-3, 5-6), then, once a request asks for a WebSocket, the
 * client's frame headers (RFC 6455 Sec. 5.2).
 *
 * WHY: libwebsockets 4.1 (Debian 12's) reads the socket and parses HTTP and WebSocket framing
 * before any code of the daemon sees a byte, and three checks are missing there:
 *  - a client frame without the mask bit is accepted (RFC 6455 Sec. 5.1: "The server MUST close
 *    the connection upon receiving a frame that is not masked"); lws records the bit
 *    (lib/roles/ws/ops-ws.c, this_frame_masked) and never looks at it. Upstream added the check
 *    after the 4.1 releases (close 1002 "client unmasked").
 *  - a request whose head overflows lws's header buffer, or that repeats headers lws knows (or
 *    query arguments) more often than its fragment table holds (95 entries), makes lws_parse fail
 *    and the connection close unanswered; RFC 6585 Sec. 5 has 431 for it (414 in the
 *    request-target, RFC 9110 Sec. 15.5.15).
 *  - "%00" in the request-target is decoded by lws as it parses, and either cuts the path or
 *    fails the request without a callback; it is answered 400 here (a NUL in a field is
 *    rejected, RFC 9110 Sec. 5.5).
 * The daemon interposes recv() (wire_guard_io.c) so that this parser sees exactly the bytes lws
 * receives, in order, and hands lws only the bytes before the one that decides a verdict.
 *
 * What it parses (everything else is left to lws):
 *  - a request head: optional empty lines, the request line, header lines up to an empty line
 *    (CRLF or bare LF). Counted: its bytes (limit max_head, RFC 6585 Sec. 5), header lines whose
 *    name lws knows plus query arguments ('?', '&', ';': each takes one lws fragment; limit
 *    max_fields). Read: Upgrade (contains "websocket": frames follow the head), Content-Length
 *    (a body of that many bytes follows, skipped; RFC 9112 Sec. 6.3: not digits, or two that
 *    differ, is 400), Transfer-Encoding (501: no request of this daemon has content, RFC 9112
 *    Sec. 6.1). A raw NUL anywhere in the head, "%00" in the request-target, or an obs-fold (a
 *    header line starting with a space, RFC 9112 Sec. 5.2) is 400.
 *  - WebSocket frames (RFC 6455 Sec. 5.2): byte 0 (FIN, RSV, opcode), byte 1 (MASK, 7-bit length),
 *    the 16- or 64-bit extended length, the 4-byte masking key, then the payload, skipped. A
 *    frame whose MASK bit is clear is the verdict SRV_GUARD_UNMASKED, at its byte 1.
 * Memory: the state is the struct below; nothing is buffered, so a header or frame may be split
 * at any byte across calls. */
#ifndef MESHSTEER_SERVER_WIRE_GUARD_H
#define MESHSTEER_SERVER_WIRE_GUARD_H

#include <stddef.h>
#include <stdint.h>

enum {
    SRV_GUARD_PASS = 0,
    SRV_GUARD_BAD_REQUEST = 400,
    SRV_GUARD_URI_TOO_LONG = 414,
    SRV_GUARD_HEADERS_TOO_LARGE = 431,
    SRV_GUARD_NOT_IMPLEMENTED = 501,
    SRV_GUARD_UNMASKED = 1002, /* RFC 6455 Sec. 7.4.1: protocol error */
};

/* What the parser knows of lws: names (lowercase, without the colon) of the headers lws stores in
 * its fragment table, as FNV-1a hashes sorted ascending (a collision only counts an unknown
 * header as known: stricter, never looser). */
typedef struct srv_guard_rules {
    uint32_t max_head;   /* bytes of one request head, the last empty line included */
    uint32_t max_fields; /* known header lines plus query arguments in one request */
    const uint32_t *known;
    int nknown;
} srv_guard_rules;

typedef struct srv_guard {
    const srv_guard_rules *rules;
    uint16_t verdict;  /* SRV_GUARD_*; sticky */
    uint8_t phase;     /* request start, head, body, websocket */
    uint8_t part;      /* request line: method, target, version; header: name, value */
    uint8_t line_empty;/* the current line has had no byte but CR */
    uint8_t in_query;  /* the target's query */
    uint8_t pct;       /* "%00" matched so far in the target: 0-2 */
    uint8_t hdr;       /* the header whose value is being read */
    uint8_t match;     /* "websocket" matched so far in an Upgrade value */
    uint8_t upgrade, chunked, bad, cl_seen, cl_state;
    uint8_t ws_state, ws_need; /* frame header: which part, bytes of it still due */
    uint8_t ws_any;            /* a byte was read as a frame */
    uint32_t head_len, fields, name_hash;
    uint64_t cl, cl_now; /* Content-Length: the agreed value, the value being read */
    uint64_t remaining;  /* body or payload bytes still to skip; extended length being read */
    uint64_t heads;      /* request heads completed */
} srv_guard;

/* srv_guard_hash of the names the parser reads (test_wire_guard.c checks them) */
#define SRV_GUARD_HASH_UPGRADE 0xdc97cc77u
#define SRV_GUARD_HASH_CONTENT_LENGTH 0x4df9451du
#define SRV_GUARD_HASH_TRANSFER_ENCODING 0xddb4744cu

/* FNV-1a over a lowercase name, as srv_guard_feed hashes header names. */
uint32_t srv_guard_hash(const char *name, size_t len);

void srv_guard_init(srv_guard *g, const srv_guard_rules *rules);

/* The next n bytes the client sent. Returns how many of them may go on to lws: n, or, when a
 * verdict falls at byte i of them, i (g->verdict says which); after a verdict, 0. */
size_t srv_guard_feed(srv_guard *g, const unsigned char *p, size_t n);

/* Nonzero while g is reading WebSocket frames (after a head asking for the upgrade). */
int srv_guard_is_websocket(const srv_guard *g);

/* The head that asked for an upgrade was answered as a plain HTTP request after all: what follows
 * is the next request. Returns -1 if bytes after that head were already read as frames (the
 * connection must close: the guard and lws no longer agree where they are), else 0. */
int srv_guard_not_upgraded(srv_guard *g);

#endif
