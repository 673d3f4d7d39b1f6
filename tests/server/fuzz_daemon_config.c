/* fuzz_daemon_config.c - fuzz target for the meshsteerd config file parser. */
#include "daemon_config.h"

#include <stdint.h>
#include <stdio.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    srv_config c;
    char err[SRV_ERR_LEN];
    srv_config_defaults(&c);
    if (srv_config_parse(&c, (const char *)data, size, "fuzz.conf", err) == 0)
        srv_config_validate(&c, err);
    return 0;
}
