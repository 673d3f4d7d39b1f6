/* wire_guard.c - the byte-by-byte check of what a client sends before libwebsockets 4.1 parses it:
 * request heads (RFC 9112 Sec. 2.2, 3, 5, 6.1, 6.3; RFC 6585 Sec. 5) and client frame headers
 * (RFC 6455 Sec. 5.1, 5.2). Why it exists and what it checks: wire_guard.h. One state machine; no
 * buffering, so any split of the input across calls gives the same verdict at the same byte. */
#include "wire_guard.h"

enum { PH_START, PH_HEAD, PH_BODY, PH_WS };
enum { RL_METHOD, RL_TARGET, RL_VERSION, HD_NAME, HD_VALUE };
enum { H_OTHER, H_UPGRADE, H_CONTENT_LENGTH, H_TRANSFER_ENCODING };
enum { WS_B0, WS_B1, WS_EXT, WS_KEY, WS_PAYLOAD };

#define FNV_OFFSET 2166136261u
#define FNV_PRIME 16777619u
#define CL_MAX ((uint64_t)1 << 62)

static unsigned char lower(unsigned char c)
{
    return c >= 'A' && c <= 'Z' ? (unsigned char)(c + 32) : c;
}

uint32_t srv_guard_hash(const char *name, size_t len)
{
    uint32_t h = FNV_OFFSET;
    for (size_t i = 0; i < len; i++)
        h = (h ^ lower((unsigned char)name[i])) * FNV_PRIME;
    return h;
}

static int known(const srv_guard_rules *r, uint32_t h)
{
    int lo = 0, hi = r->nknown - 1;
    while (lo <= hi) {
        int mid = lo + (hi - lo) / 2;
        if (r->known[mid] == h)
            return 1;
        if (r->known[mid] < h)
            lo = mid + 1;
        else
            hi = mid - 1;
    }
    return 0;
}

static void request_reset(srv_guard *g);

void srv_guard_init(srv_guard *g, const srv_guard_rules *rules)
{
    *g = (srv_guard){.rules = rules};
    request_reset(g);
}

int srv_guard_is_websocket(const srv_guard *g)
{
    return g->phase == PH_WS;
}


int srv_guard_not_upgraded(srv_guard *g)
{
    if (g->phase != PH_WS)
        return 0;
    if (g->ws_any || g->verdict)
        return -1;
    request_reset(g);
    return 0;
}

static void request_reset(srv_guard *g)
{
    g->phase = PH_START;
    g->part = RL_METHOD;
    g->line_empty = 1;
    g->in_query = g->pct = g->hdr = g->match = 0;
    g->upgrade = g->chunked = g->bad = g->cl_seen = g->cl_state = 0;
    g->head_len = g->fields = 0;
    g->cl = g->cl_now = g->remaining = 0;
}

/* The header named by g->name_hash is complete (its ':' read). */
static void header_named(srv_guard *g)
{
    uint32_t h = g->name_hash;
    g->hdr = h == SRV_GUARD_HASH_UPGRADE          ? H_UPGRADE
           : h == SRV_GUARD_HASH_CONTENT_LENGTH   ? H_CONTENT_LENGTH
           : h == SRV_GUARD_HASH_TRANSFER_ENCODING ? H_TRANSFER_ENCODING
                                                  : H_OTHER;
    g->match = 0;
    g->cl_now = 0;
    g->cl_state = 0;
    if (g->hdr == H_TRANSFER_ENCODING)
        g->chunked = 1;
}

/* A header value byte (CR and LF excluded). */
static void value_byte(srv_guard *g, unsigned char c)
{
    static const char ws[] = "websocket";
    if (g->hdr == H_UPGRADE && g->match < sizeof ws - 1) {
        /* "websocket" has no proper prefix that is also a suffix: a mismatch restarts at 0 or 1 */
        c = lower(c);
        g->match = c == (unsigned char)ws[g->match] ? (uint8_t)(g->match + 1) : c == 'w';
        if (g->match == sizeof ws - 1)
            g->upgrade = 1;
    } else if (g->hdr == H_CONTENT_LENGTH) {
        /* OWS digits OWS (RFC 9112 Sec. 6.3, RFC 9110 Sec. 8.6) */
        if (c == ' ' || c == '\t') {
            if (g->cl_state == 1)
                g->cl_state = 2;
        } else if (c >= '0' && c <= '9' && g->cl_state < 2) {
            g->cl_state = 1;
            g->cl_now = g->cl_now * 10 + (uint64_t)(c - '0');
            if (g->cl_now > CL_MAX)
                g->bad = 1;
        } else {
            g->bad = 1;
        }
    }
}

/* The end of a header line (its LF): a Content-Length must have had digits and agree with any
 * earlier one. */
static void header_done(srv_guard *g)
{
    if (g->part == HD_VALUE && g->hdr == H_CONTENT_LENGTH) {
        if (g->cl_state == 0 || (g->cl_seen && g->cl != g->cl_now))
            g->bad = 1;
        g->cl = g->cl_now;
        g->cl_seen = 1;
    }
}

/* The head's last LF: a verdict, or what follows it. Returns the verdict. */
static int head_done(srv_guard *g)
{
    if (g->bad)
        return SRV_GUARD_BAD_REQUEST;
    if (g->chunked)
        return SRV_GUARD_NOT_IMPLEMENTED;
    g->heads++;
    if (g->upgrade) {
        g->phase = PH_WS;
        g->ws_state = WS_B0;
        g->ws_any = 0;
        return SRV_GUARD_PASS;
    }
    uint64_t body = g->cl;
    request_reset(g);
    if (body) {
        g->phase = PH_BODY;
        g->remaining = body;
    }
    return SRV_GUARD_PASS;
}

/* One byte of a request head; returns a verdict or SRV_GUARD_PASS. */
static int head_byte(srv_guard *g, unsigned char c)
{
    const srv_guard_rules *r = g->rules;
    if (++g->head_len > r->max_head)
        return g->part == RL_TARGET ? SRV_GUARD_URI_TOO_LONG : SRV_GUARD_HEADERS_TOO_LARGE;
    if (c == 0)
        return SRV_GUARD_BAD_REQUEST;
    if (c == '\r')
        return SRV_GUARD_PASS; /* line ends are LF, with or without CR before it */
    if (c == '\n') {
        if (g->part <= RL_VERSION) { /* the end of the request line */
            g->part = HD_NAME;
            g->line_empty = 1;
            return SRV_GUARD_PASS;
        }
        if (g->line_empty)
            return head_done(g);
        header_done(g);
        g->part = HD_NAME;
        g->line_empty = 1;
        return SRV_GUARD_PASS;
    }
    int first = g->line_empty;
    g->line_empty = 0;
    switch (g->part) {
    case RL_METHOD:
        if (c == ' ')
            g->part = RL_TARGET;
        return SRV_GUARD_PASS;
    case RL_TARGET:
        if (c == ' ') {
            g->part = RL_VERSION;
            return SRV_GUARD_PASS;
        }
        if (c == '?' && !g->in_query) {
            g->in_query = 1;
            g->fields++;
        } else if (g->in_query && (c == '&' || c == ';')) {
            g->fields++;
        }
        if (g->fields > r->max_fields)
            return SRV_GUARD_URI_TOO_LONG;
        g->pct = c == '%' ? 1 : g->pct && c == '0' ? (uint8_t)(g->pct + 1) : 0;
        return g->pct == 3 ? SRV_GUARD_BAD_REQUEST : SRV_GUARD_PASS;
    case RL_VERSION:
        return SRV_GUARD_PASS;
    case HD_NAME:
        if (first && (c == ' ' || c == '\t'))
            return SRV_GUARD_BAD_REQUEST; /* obs-fold (RFC 9112 Sec. 5.2: reject it, or unfold) */
        if (first) {
            g->name_hash = FNV_OFFSET;
            g->hdr = H_OTHER;
        }
        if (c != ':') {
            g->name_hash = (g->name_hash ^ lower(c)) * FNV_PRIME;
            return SRV_GUARD_PASS;
        }
        g->part = HD_VALUE;
        header_named(g);
        if (known(r, g->name_hash) && ++g->fields > r->max_fields)
            return SRV_GUARD_HEADERS_TOO_LARGE;
        return SRV_GUARD_PASS;
    default:
        value_byte(g, c);
        return SRV_GUARD_PASS;
    }
}

/* One byte of a client frame header (RFC 6455 Sec. 5.2); returns a verdict or SRV_GUARD_PASS. */
static int frame_byte(srv_guard *g, unsigned char c)
{
    g->ws_any = 1;
    switch (g->ws_state) {
    case WS_B0: /* FIN, RSV1-3, opcode: lws checks them */
        g->ws_state = WS_B1;
        return SRV_GUARD_PASS;
    case WS_B1:
        if (!(c & 0x80))
            return SRV_GUARD_UNMASKED; /* Sec. 5.1 */
        c &= 0x7f;
        g->remaining = c < 126 ? c : 0;
        g->ws_need = c == 126 ? 2 : c == 127 ? 8 : 4;
        g->ws_state = c < 126 ? WS_KEY : WS_EXT;
        return SRV_GUARD_PASS;
    case WS_EXT:
        g->remaining = g->remaining << 8 | c;
        if (--g->ws_need == 0) {
            g->ws_state = WS_KEY;
            g->ws_need = 4;
        }
        return SRV_GUARD_PASS;
    default: /* WS_KEY */
        if (--g->ws_need == 0)
            g->ws_state = g->remaining ? WS_PAYLOAD : WS_B0;
        return SRV_GUARD_PASS;
    }
}

size_t srv_guard_feed(srv_guard *g, const unsigned char *p, size_t n)
{
    if (g->verdict)
        return 0;
    size_t i = 0;
    while (i < n) {
        int v = SRV_GUARD_PASS;
        switch (g->phase) {
        case PH_BODY:
        case PH_WS:
            if (g->phase == PH_BODY || g->ws_state == WS_PAYLOAD) {
                uint64_t take = n - i < g->remaining ? n - i : g->remaining;
                i += (size_t)take;
                g->remaining -= take;
                if (g->remaining == 0) {
                    if (g->phase == PH_BODY)
                        request_reset(g);
                    else
                        g->ws_state = WS_B0;
                }
                continue;
            }
            v = frame_byte(g, p[i]);
            break;
        case PH_START:
            /* empty lines before a request (RFC 9112 Sec. 2.2) count towards its head's size */
            if (p[i] == '\r' || p[i] == '\n') {
                if (++g->head_len > g->rules->max_head)
                    v = SRV_GUARD_HEADERS_TOO_LARGE;
                break;
            }
            g->phase = PH_HEAD;
            v = head_byte(g, p[i]);
            break;
        default:
            v = head_byte(g, p[i]);
            break;
        }
        if (v != SRV_GUARD_PASS) {
            g->verdict = (uint16_t)v;
            return i;
        }
        i++;
    }
    return n;
}
