/* fuzz_wire_guard.c - fuzz target for the wire guard's parser (server/wire_guard.c): the input is
 * fed whole and again in pieces cut where the input's last bytes say; both must reach the same
 * verdict after passing the same number of bytes (nothing is buffered, so a cut changes nothing),
 * and never pass more than they were given. */
#include "wire_guard.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static uint32_t known[2];
    known[0] = srv_guard_hash("accept", 6);
    known[1] = srv_guard_hash("upgrade", 7);
    if (known[0] > known[1]) {
        uint32_t t = known[0];
        known[0] = known[1];
        known[1] = t;
    }
    srv_guard_rules rules = {512, 8, known, 2}; /* small limits: the fuzzer reaches them */
    srv_guard whole, cut;
    srv_guard_init(&whole, &rules);
    srv_guard_init(&cut, &rules);
    size_t a = srv_guard_feed(&whole, data, size);
    if (a > size)
        abort();
    size_t step = size ? (size_t)data[size - 1] % 17 + 1 : 1, at = 0, b = 0;
    while (at < size) {
        size_t len = size - at < step ? size - at : step;
        size_t k = srv_guard_feed(&cut, data + at, len);
        if (k > len)
            abort();
        b += k;
        if (k < len)
            break;
        at += len;
    }
    if (a != b || whole.verdict != cut.verdict || whole.heads != cut.heads)
        abort();
    return 0;
}
