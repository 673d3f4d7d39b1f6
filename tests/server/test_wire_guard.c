/* test_wire_guard.c - the wire guard's state machine (server/wire_guard.c): request heads (the
 * 8 KiB limit, 414 in the target, "%00", known headers lws stores, Content-Length bodies skipped,
 * Transfer-Encoding, NUL, obs-fold) and client frames after an upgrade (7-, 16- and 64-bit
 * lengths skipped, an unmasked frame found at its second byte), each fed whole, in two pieces
 * split at every byte, and one byte at a time: the verdict falls at the same byte every way. */
#include "wire_guard.h"
#include "test.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static uint32_t known[3];
static srv_guard_rules rules = {8192, 64, known, 3};

static int cmp(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

/* Feeds p in pieces of `step` bytes (0: whole); returns the bytes passed, the verdict in *v. */
static size_t feed(const unsigned char *p, size_t n, size_t first, size_t step, int *v)
{
    srv_guard g;
    srv_guard_init(&g, &rules);
    size_t passed = 0, at = 0;
    while (at < n) {
        size_t len = at == 0 && first ? first : step ? step : n - at;
        if (len > n - at)
            len = n - at;
        size_t k = srv_guard_feed(&g, p + at, len);
        passed += k;
        if (k < len)
            break;
        at += len;
    }
    *v = g.verdict;
    return passed;
}

/* The verdict and where it falls are the same whole, split at every byte, and byte by byte. */
static void expect(const unsigned char *p, size_t n, int verdict, size_t at)
{
    int v;
    size_t k = feed(p, n, 0, 0, &v);
    ASSERT_INT_EQ(v, verdict);
    ASSERT_INT_EQ((long long)k, (long long)at);
    k = feed(p, n, 0, 1, &v);
    ASSERT_INT_EQ(v, verdict);
    ASSERT_INT_EQ((long long)k, (long long)at);
    for (size_t s = 1; s < n; s += n > 4096 ? 97 : 1) {
        k = feed(p, n, s, 0, &v);
        ASSERT_INT_EQ(v, verdict);
        ASSERT_INT_EQ((long long)k, (long long)at);
    }
}

static void expect_str(const char *s, int verdict, const char *at)
{
    size_t n = strlen(s);
    expect((const unsigned char *)s, n, verdict, at ? (size_t)(strstr(s, at) - s) : n);
}

/* the verdict at the head's last LF */
#define END "\r\n\r\n"
static void expect_end(const char *s, int verdict)
{
    expect((const unsigned char *)s, strlen(s), verdict, (size_t)(strstr(s, END) - s) + 3);
}

static const char upgrade[] = "GET /stream HTTP/1.1\r\nHost: h\r\nUpgrade: WebSocket\r\n"
                              "Connection: Upgrade\r\n"
                              "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                              "Sec-WebSocket-Version: 13\r\n\r\n";

/* A masked client frame of opcode op and len payload bytes at b; returns its size. */
static size_t frame(unsigned char *b, int op, size_t len, int masked)
{
    size_t h = 0;
    b[h++] = (unsigned char)(0x80 | op);
    unsigned char m = masked ? 0x80 : 0;
    if (len < 126) {
        b[h++] = (unsigned char)(m | len);
    } else if (len < 65536) {
        b[h++] = m | 126;
        b[h++] = (unsigned char)(len >> 8);
        b[h++] = (unsigned char)len;
    } else {
        b[h++] = m | 127;
        for (int i = 7; i >= 0; i--)
            b[h++] = (unsigned char)((uint64_t)len >> (8 * i));
    }
    if (masked)
        for (int i = 0; i < 4; i++)
            b[h++] = (unsigned char)(0x11 * (i + 1));
    for (size_t i = 0; i < len; i++) /* payload bytes that look like frame headers */
        b[h + i] = i % 2 ? 0x01 : 0x81;
    return h + len;
}

static void test_frames(void)
{
    size_t cap = sizeof upgrade + 200000;
    unsigned char *b = malloc(cap);
    ASSERT(b);
    size_t n = sizeof upgrade - 1;
    memcpy(b, upgrade, n);
    n += frame(b + n, 1, 4, 1);      /* 7-bit */
    n += frame(b + n, 9, 0, 1);      /* empty ping */
    n += frame(b + n, 2, 300, 1);    /* 16-bit */
    n += frame(b + n, 2, 70000, 1);  /* 64-bit */
    n += frame(b + n, 1, 125, 1);
    expect(b, n, SRV_GUARD_PASS, n); /* every masked frame passes, however it is cut */
    size_t bad = n;
    n += frame(b + n, 1, 4, 0);      /* unmasked, after them: found at its byte 1 */
    expect(b, n, SRV_GUARD_UNMASKED, bad + 1);
    /* an unmasked first frame, and one behind a 16-bit length */
    n = sizeof upgrade - 1;
    bad = n;
    n += frame(b + n, 1, 10, 0);
    expect(b, n, SRV_GUARD_UNMASKED, bad + 1);
    n = sizeof upgrade - 1;
    n += frame(b + n, 2, 1000, 1);
    bad = n;
    n += frame(b + n, 2, 1000, 0);
    expect(b, n, SRV_GUARD_UNMASKED, bad + 1);
    /* no upgrade asked: the same bytes after a plain request are the next request's */
    n = 0;
    const char plain[] = "GET / HTTP/1.1\r\nHost: h\r\n\r\n";
    memcpy(b, plain, sizeof plain - 1);
    n = sizeof plain - 1;
    n += frame(b + n, 1, 10, 0);
    int v;
    feed(b, n, 0, 0, &v);
    ASSERT_INT_EQ(v, SRV_GUARD_PASS);
    /* an upgrade lws answers as plain HTTP: the guard reads the next request as a request */
    {
        srv_guard g;
        srv_guard_init(&g, &rules);
        const unsigned char *u = (const unsigned char *)upgrade;
        ASSERT_INT_EQ((long long)srv_guard_feed(&g, u, sizeof upgrade - 1),
                      (long long)(sizeof upgrade - 1));
        ASSERT(srv_guard_is_websocket(&g));
        ASSERT_INT_EQ(srv_guard_not_upgraded(&g), 0);
        const char next[] = "GET /%00 HTTP/1.1\r\n\r\n";
        const unsigned char *x = (const unsigned char *)next;
        ASSERT_INT_EQ((long long)srv_guard_feed(&g, x, sizeof next - 1), 7);
        ASSERT_INT_EQ(g.verdict, SRV_GUARD_BAD_REQUEST);
        srv_guard_init(&g, &rules); /* with a frame byte already read: the connection must go */
        srv_guard_feed(&g, (const unsigned char *)upgrade, sizeof upgrade - 1);
        srv_guard_feed(&g, (const unsigned char *)"\x81", 1);
        ASSERT_INT_EQ(srv_guard_not_upgraded(&g), -1);
    }
    free(b);
    printf("frames: 7/16/64-bit lengths skipped at every split, unmasked found at its byte 1\n");
}

static void test_heads(void)
{
    expect_str("GET /healthz HTTP/1.1\r\nHost: h\r\n\r\nGET / HTTP/1.1\r\n\r\n", SRV_GUARD_PASS,
               NULL);
    /* bare LF, an empty line first */
    expect_str("\r\nGET / HTTP/1.1\nHost: h\n\n", SRV_GUARD_PASS, NULL);
    expect_str("GET /%00 HTTP/1.1\r\nHost: h\r\n\r\n", SRV_GUARD_BAD_REQUEST, "0 HTTP");
    expect_str("GET /a?x=1&y=%00 HTTP/1.1\r\n\r\n", SRV_GUARD_BAD_REQUEST, "0 HTTP");
    expect_str("GET /%2500 HTTP/1.1\r\n\r\n", SRV_GUARD_PASS, NULL); /* "%25" then "00" */
    expect_str("GET / HTTP/1.1\r\nX-A: %00\r\n\r\n", SRV_GUARD_PASS, NULL); /* only the target */
    expect((const unsigned char *)"GET / HTTP/1.1\r\nX-A: a\0b\r\n\r\n", 28, SRV_GUARD_BAD_REQUEST,
           22);
    expect_str("GET / HTTP/1.1\r\nX-A: a\r\n b\r\n\r\n", SRV_GUARD_BAD_REQUEST, " b\r\n\r\n");
    /* Content-Length: the body is skipped, even when it looks like a request */
    {
        const char *s = "POST / HTTP/1.1\r\nContent-Length: 10\r\n\r\nGET /%00 HGET /%00 H";
        expect((const unsigned char *)s, strlen(s), SRV_GUARD_BAD_REQUEST, strlen(s) - 3);
    }
    expect_end("POST / HTTP/1.1\r\nContent-Length: 1x\r\n\r\n", SRV_GUARD_BAD_REQUEST);
    expect_end("POST / HTTP/1.1\r\nContent-Length: 1\r\ncontent-length: 2\r\n\r\n",
               SRV_GUARD_BAD_REQUEST);
    expect_str("POST / HTTP/1.1\r\nContent-Length:  3 \r\ncontent-length: 3\r\n\r\nabc",
               SRV_GUARD_PASS, NULL);
    expect_end("POST / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n", SRV_GUARD_NOT_IMPLEMENTED);
    printf("heads: %%00 in the target 400, NUL and obs-fold 400, bodies skipped, chunked 501\n");
}

static void test_limits(void)
{
    char *r = malloc(20000);
    ASSERT(r);
    /* a head of exactly 8192 bytes passes; one byte more is 431 at that byte */
    for (int extra = 0; extra < 2; extra++) {
        int n = snprintf(r, 20000, "GET / HTTP/1.1\r\nX-Pad: ");
        int pad = 8192 - n - 4 + extra;
        memset(r + n, 'a', (size_t)pad);
        n += pad;
        n += snprintf(r + n, 20000 - (size_t)n, "\r\n\r\n");
        ASSERT_INT_EQ(n, 8192 + extra);
        expect((unsigned char *)r, (size_t)n, extra ? SRV_GUARD_HEADERS_TOO_LARGE : SRV_GUARD_PASS,
               extra ? 8192 : (size_t)n);
    }
    /* in the request-target: 414 */
    int n = snprintf(r, 20000, "GET /?q=");
    memset(r + n, 'a', 9000);
    n += 9000;
    n += snprintf(r + n, 20000 - (size_t)n, " HTTP/1.1\r\n\r\n");
    expect((unsigned char *)r, (size_t)n, SRV_GUARD_URI_TOO_LONG, 8192);
    /* 64 headers lws knows pass, the 65th is 431 at its ':'; 150 it does not know pass */
    for (int k = 0; k < 3; k++) {
        n = snprintf(r, 20000, "GET / HTTP/1.1\r\n");
        int count = k == 0 ? 64 : k == 1 ? 65 : 150;
        size_t at = 0;
        for (int i = 0; i < count; i++) {
            if (i == 64)
                at = (size_t)n + 6;
            n += snprintf(r + n, 20000 - (size_t)n, k < 2 ? "Accept: x\r\n" : "X-H%03d: x\r\n", i);
        }
        n += snprintf(r + n, 20000 - (size_t)n, "\r\n");
        expect((unsigned char *)r, (size_t)n, k == 1 ? SRV_GUARD_HEADERS_TOO_LARGE : SRV_GUARD_PASS,
               k == 1 ? at : (size_t)n);
    }
    /* query arguments take lws fragments too: 70 of them are 414 at the 65th's separator */
    n = snprintf(r, 20000, "GET /?a");
    for (int i = 1; i < 70; i++)
        n += snprintf(r + n, 20000 - (size_t)n, "&a");
    n += snprintf(r + n, 20000 - (size_t)n, " HTTP/1.1\r\n\r\n");
    expect((unsigned char *)r, (size_t)n, SRV_GUARD_URI_TOO_LONG, 7 + 2 * 63);
    free(r);
    printf("limits: 8192-byte head passes, 8193 is 431; 9 KB target 414; 65 known headers 431\n");
}

int main(void)
{
    known[0] = srv_guard_hash("accept", 6);
    known[1] = srv_guard_hash("host", 4);
    known[2] = srv_guard_hash("upgrade", 7);
    qsort(known, 3, sizeof known[0], cmp);
    ASSERT_INT_EQ(srv_guard_hash("Upgrade", 7), SRV_GUARD_HASH_UPGRADE);
    ASSERT_INT_EQ(srv_guard_hash("content-length", 14), SRV_GUARD_HASH_CONTENT_LENGTH);
    ASSERT_INT_EQ(srv_guard_hash("Transfer-Encoding", 17), SRV_GUARD_HASH_TRANSFER_ENCODING);
    test_heads();
    test_limits();
    test_frames();
    return 0;
}
