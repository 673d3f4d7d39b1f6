/* wsframe.c - RFC 6455 frames from the server's side of the stream, parsed as a stream
 * (see wsframe.h). Base framing, Sec. 5.2:
 *   byte 0: FIN (0x80), RSV1-3 (0x70), opcode (0x0f)
 *   byte 1: MASK (0x80), payload length 0-125, or 126 (+ 16-bit length) or 127 (+ 64-bit length)
 *   then the payload (unmasked from a server). */
#include "wsframe.h"

#include <string.h>

void ws_rx_init(ws_rx *r, size_t keep)
{
    memset(r, 0, sizeof *r);
    r->keep = keep < WS_KEEP_MAX ? keep : WS_KEEP_MAX;
    r->fh_need = 2;
}

static int stop(ws_rx *r, const char *why)
{
    r->error = why;
    return -1;
}

/* The current frame's payload is all in. */
static int frame_done(ws_rx *r, const ws_rx_cb *cb)
{
    r->fh_len = 0;
    r->fh_need = 2;
    if (r->opcode >= WS_OP_CLOSE)
        return cb->control ? cb->control(cb->ud, r->opcode, r->ctl, r->ctl_len) : 0;
    if (r->fin) {
        r->in_msg = 0;
        if (cb->message)
            cb->message(cb->ud, r->msg_binary, r->head, r->head_len, r->msg_len);
    }
    return 0;
}

/* A complete frame header in r->fh. */
static int header_done(ws_rx *r, const ws_rx_cb *cb)
{
    unsigned len7 = r->fh[1] & 0x7fu;
    uint64_t len = len7;
    if (len7 == 126) {
        len = (uint64_t)r->fh[2] << 8 | r->fh[3];
    } else if (len7 == 127) {
        len = 0;
        for (int i = 0; i < 8; i++)
            len = len << 8 | r->fh[2 + i];
        if (len >> 63)
            return stop(r, "64-bit payload length with the top bit set");
    }
    r->opcode = r->fh[0] & 0x0f;
    r->fin = (r->fh[0] & 0x80) != 0;
    r->remaining = len;
    if (r->opcode >= WS_OP_CLOSE) {
        if (r->opcode > WS_OP_PONG)
            return stop(r, "unknown control opcode");
        if (!r->fin || len > 125)
            return stop(r, "fragmented or oversized control frame");
        r->ctl_len = 0;
    } else if (r->opcode == WS_OP_TEXT || r->opcode == WS_OP_BINARY) {
        if (r->in_msg)
            return stop(r, "new message inside a fragmented one");
        r->in_msg = 1;
        r->msg_binary = r->opcode == WS_OP_BINARY;
        r->head_len = 0;
        r->msg_len = 0;
    } else if (r->opcode == WS_OP_CONT) {
        if (!r->in_msg)
            return stop(r, "continuation frame without a message");
    } else {
        return stop(r, "unknown data opcode");
    }
    return len == 0 ? frame_done(r, cb) : 0;
}

int ws_rx_feed(ws_rx *r, const unsigned char *p, size_t n, const ws_rx_cb *cb)
{
    if (r->error)
        return -1;
    while (n > 0) {
        if (r->fh_len < r->fh_need) {
            r->fh[r->fh_len++] = *p++;
            n--;
            if (r->fh_len == 2) {
                if (r->fh[1] & 0x80)
                    return stop(r, "masked frame from the server");
                if (r->fh[0] & 0x70)
                    return stop(r, "RSV bits set but no extension was negotiated");
                unsigned len7 = r->fh[1] & 0x7fu;
                r->fh_need = 2 + (len7 == 126 ? 2u : len7 == 127 ? 8u : 0u);
            }
            if (r->fh_len == r->fh_need) {
                int rc = header_done(r, cb);
                if (rc)
                    return rc;
            }
            continue;
        }
        size_t k = r->remaining < n ? (size_t)r->remaining : n;
        if (r->opcode >= WS_OP_CLOSE) {
            memcpy(r->ctl + r->ctl_len, p, k); /* k <= 125 - ctl_len: remaining started <= 125 */
            r->ctl_len += k;
        } else {
            if (r->head_len < r->keep) {
                size_t h = k < r->keep - r->head_len ? k : r->keep - r->head_len;
                memcpy(r->head + r->head_len, p, h);
                r->head_len += h;
            }
            r->msg_len += k;
        }
        p += k;
        n -= k;
        r->remaining -= k;
        if (r->remaining == 0) {
            int rc = frame_done(r, cb);
            if (rc)
                return rc;
        }
    }
    return 0;
}

long ws_handshake_end(const char *buf, size_t len)
{
    static const char status[] = "HTTP/1.1 ";
    size_t sl = sizeof status - 1;
    size_t cmp = len < sl ? len : sl;
    if (memcmp(buf, status, cmp))
        return -1;
    if (len >= sl + 3 && memcmp(buf + sl, "101", 3))
        return -1;
    for (size_t i = 0; i + 3 < len; i++)
        if (buf[i] == '\r' && buf[i + 1] == '\n' && buf[i + 2] == '\r' && buf[i + 3] == '\n')
            return len >= sl + 3 ? (long)(i + 4) : -1;
    return 0;
}
