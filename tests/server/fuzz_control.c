/* fuzz_control.c - fuzz target for /stream control messages and their replies. */
#include "control.h"

#include <stdint.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    srv_control c;
    const char *code;
    char msg[256], buf[SRV_REPLY_LEN];
    if (srv_control_parse((const char *)data, size, &c, &code, msg, sizeof msg) == 0)
        srv_reply_ack(buf, &c);
    else
        srv_reply_error(buf, code, msg, &c);
    return 0;
}
