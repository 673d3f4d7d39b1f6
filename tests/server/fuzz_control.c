/* fuzz_control.c - fuzz target for /stream control messages and their replies: every reply is
 * valid UTF-8 (a text frame that is not fails the client's connection, RFC 6455 Sec. 8.1) and
 * fits its buffer. */
#include "control.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void check(const char *reply, size_t n)
{
    if (n >= SRV_REPLY_LEN || strlen(reply) != n || !srv__utf8_valid(reply, n)) {
        fprintf(stderr, "reply of %zu bytes is not valid UTF-8 text: %s\n", n, reply);
        abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    srv_control c;
    const char *code;
    char msg[256], buf[SRV_REPLY_LEN];
    size_t n;
    if (srv_control_parse((const char *)data, size, &c, &code, msg, sizeof msg) == 0)
        n = srv_reply_ack(buf, &c, -1);
    else
        n = srv_reply_error(buf, code, msg, &c);
    check(buf, n);
    /* an error text from elsewhere (a source's, naming a file) passes through the same reply */
    char text[300];
    size_t k = size < sizeof text - 1 ? size : sizeof text - 1;
    memcpy(text, data, k);
    text[k] = '\0';
    check(buf, srv_reply_error(buf, "source_error", text, &c));
    return 0;
}
