/* fuzz_wsframe.c - fuzz target for the load client's WebSocket receive side (clients/wsframe.c):
 * the handshake response, then the frames, fed in two pieces split at a point the input chooses. */
#include "wsframe.h"

#include <stdint.h>
#include <string.h>

static void on_message(void *ud, int binary, const unsigned char *head, size_t head_len,
                       uint64_t len)
{
    size_t *sum = ud;
    *sum += (size_t)binary + head_len + (size_t)len + (head_len ? head[0] : 0);
}

static int on_control(void *ud, int opcode, const unsigned char *payload, size_t len)
{
    size_t *sum = ud;
    *sum += (size_t)opcode + len + (len ? payload[len - 1] : 0);
    return opcode == WS_OP_CLOSE;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    long end = ws_handshake_end((const char *)data, size);
    size_t off = end > 0 ? (size_t)end : 0;
    size_t sum = 0;
    ws_rx_cb cb = {on_message, on_control, &sum};
    ws_rx r;
    ws_rx_init(&r, 56);
    size_t rest = size - off, split = rest ? data[size - 1] % (rest + 1) : 0;
    if (ws_rx_feed(&r, data + off, split, &cb) == 0)
        ws_rx_feed(&r, data + off + split, rest - split, &cb);
    return sum == (size_t)-1; /* keeps sum alive */
}
