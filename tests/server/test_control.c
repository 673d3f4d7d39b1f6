/* test_control.c - validation of /stream control messages and the replies' JSON. */
#include "control.h"
#include "encode.h"
#include "test.h"

#include <cjson/cJSON.h>
#include <string.h>

static int parse(const char *txt, srv_control *c, const char **code, char *msg)
{
    return srv_control_parse(txt, strlen(txt), c, code, msg, 256);
}

int main(void)
{
    srv_control c;
    const char *code;
    char msg[256], buf[SRV_REPLY_LEN];

    ASSERT_OK(parse("{\"type\":\"encoding\",\"encoding\":\"int16\",\"id\":5}", &c, &code, msg), msg);
    ASSERT_INT_EQ(c.kind, SRV_CTL_ENCODING);
    ASSERT_INT_EQ(c.encoding, SRV_ENC_INT16);
    ASSERT(!strcmp(c.id, "5"));
    ASSERT_OK(parse(" {\"type\":\"seek\",\"frame\":120} \n", &c, &code, msg), msg);
    ASSERT_INT_EQ(c.kind, SRV_CTL_SEEK);
    ASSERT_NEAR(c.value, 120, 0);
    ASSERT_OK(parse("{\"type\":\"speed\",\"speed\":0.5,\"id\":\"x-1\"}", &c, &code, msg), msg);
    ASSERT_NEAR(c.value, 0.5, 0);
    ASSERT(!strcmp(c.id, "\"x-1\""));
    ASSERT_OK(parse("{\"type\":\"pause\"}", &c, &code, msg), msg);
    ASSERT_INT_EQ(c.kind, SRV_CTL_PAUSE);
    ASSERT_OK(parse("{\"type\":\"resume\"}", &c, &code, msg), msg);
    ASSERT_OK(parse("{\"type\":\"ping\",\"id\":1}", &c, &code, msg), msg);

    static const struct { const char *txt, *code, *type; } bad[] = {
        {"", "malformed", NULL},
        {"hello", "malformed", NULL},
        {"[1,2]", "malformed", NULL},
        {"{\"type\":\"pause\"} x", "malformed", NULL},
        {"{\"type\":\"pause\"", "malformed", NULL},
        {"{}", "bad_field", NULL},
        {"{\"type\":3}", "bad_field", NULL},
        {"{\"type\":\"dance\"}", "unknown_type", NULL},
        {"{\"type\":\"pause\",\"now\":true}", "bad_field", "pause"},
        {"{\"type\":\"encoding\"}", "bad_field", "encoding"},
        {"{\"type\":\"encoding\",\"encoding\":\"float64\"}", "bad_field", "encoding"},
        {"{\"type\":\"encoding\",\"encoding\":16}", "bad_field", "encoding"},
        {"{\"type\":\"seek\",\"frame\":-1}", "bad_field", "seek"},
        {"{\"type\":\"seek\",\"frame\":1.5}", "bad_field", "seek"},
        {"{\"type\":\"seek\",\"frame\":\"10\"}", "bad_field", "seek"},
        {"{\"type\":\"seek\",\"frame\":1e12}", "bad_field", "seek"},
        /* the range is the source's (drv_source_control), the type is the message's */
        {"{\"type\":\"speed\",\"speed\":\"2\"}", "bad_field", "speed"},
        {"{\"type\":\"speed\",\"speed\":true}", "bad_field", "speed"},
        {"{\"type\":\"ping\",\"id\":{}}", "bad_field", NULL},
        {"{\"type\":\"ping\",\"id\":\"0123456789012345678901234567890123456789012345678901234567890123456789\"}",
         "bad_field", NULL},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        code = NULL;
        int r = parse(bad[i].txt, &c, &code, msg);
        if (r == 0 || !code || strcmp(code, bad[i].code) ||
            (bad[i].type && (!c.type || strcmp(c.type, bad[i].type)))) {
            fprintf(stderr, "case %zu '%s': got %d code %s type %s (%s)\n", i, bad[i].txt, r,
                    code ? code : "-", c.type ? c.type : "-", msg);
            return 1;
        }
    }
    /* a NUL byte */
    ASSERT(srv_control_parse("{\"type\":\"pause\"}\0", 17, &c, &code, msg, sizeof msg) == -1);

    /* replies are valid JSON and echo the id */
    ASSERT_OK(parse("{\"type\":\"seek\",\"frame\":3,\"id\":\"q\\\"uote\"}", &c, &code, msg), msg);
    size_t n = srv_reply_ack(buf, &c, -1);
    cJSON *j = cJSON_ParseWithLength(buf, n);
    ASSERT(j);
    ASSERT(!strcmp(cJSON_GetObjectItem(j, "type")->valuestring, "ack"));
    ASSERT(!strcmp(cJSON_GetObjectItem(j, "request")->valuestring, "seek"));
    ASSERT(!strcmp(cJSON_GetObjectItem(j, "id")->valuestring, "q\"uote"));
    ASSERT(!cJSON_GetObjectItem(j, "seq")); /* none asked for */
    cJSON_Delete(j);
    /* a source control's ack names the newest frame made before it */
    n = srv_reply_ack(buf, &c, 4294967301LL);
    j = cJSON_ParseWithLength(buf, n);
    ASSERT(j && cJSON_GetObjectItem(j, "seq")->valuedouble == 4294967301.0);
    cJSON_Delete(j);
    n = srv_reply_pong(buf, &c, 123456789);
    j = cJSON_ParseWithLength(buf, n);
    ASSERT(j && cJSON_GetObjectItem(j, "server_us")->valuedouble == 123456789);
    cJSON_Delete(j);
    /* an error reply with a hostile message stays valid JSON and within the buffer */
    char hostile[300];
    memset(hostile, '\x01', sizeof hostile - 1);
    hostile[sizeof hostile - 1] = '\0';
    n = srv_reply_error(buf, "bad_field", hostile, &c);
    ASSERT(n < SRV_REPLY_LEN);
    j = cJSON_ParseWithLength(buf, n);
    ASSERT(j && !strcmp(cJSON_GetObjectItem(j, "type")->valuestring, "error"));
    cJSON_Delete(j);
    /* UTF-8: a field name cut at 64 bytes loses the whole character that straddles the cut (a
     * lone 0xC3 made clients fail the connection with 1007); not-UTF-8 input is malformed; an
     * error text with invalid bytes is repaired */
    char txt[128];
    snprintf(txt, sizeof txt, "{\"type\":\"ping\",\"%s\xc3\xa9\":1}",
             "aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa"); /* 63 a's */
    ASSERT(parse(txt, &c, &code, msg) == -1);
    ASSERT(!strcmp(code, "bad_field"));
    printf("field name cut: %s\n", msg);
    ASSERT(strstr(msg, "aaa'") && !strchr(msg, '\xc3'));
    n = srv_reply_error(buf, code, msg, &c);
    ASSERT(srv__utf8_valid(buf, n));
    ASSERT(parse("{\"type\":\"ping\",\"id\":\"\xc3\"}", &c, &code, msg) == -1);
    ASSERT(!strcmp(code, "malformed"));
    n = srv_reply_error(buf, "source_error", "replay /tmp/\xe9t\xc3\xa9.c3d: \xf0\x9f", &c);
    ASSERT(srv__utf8_valid(buf, n));
    ASSERT(strstr(buf, "/tmp/?t\xc3\xa9.c3d: ??"));
    ASSERT(srv__utf8_valid("\xe2\x82\xac\xf0\x9f\x98\x80", 7));
    ASSERT(!srv__utf8_valid("\xc0\xaf", 2));         /* overlong */
    ASSERT(!srv__utf8_valid("\xed\xa0\x80", 3));     /* surrogate */
    ASSERT(!srv__utf8_valid("\xf4\x90\x80\x80", 4)); /* above U+10FFFF */
    /* kind names and kind sets, as the hello and the unsupported reply use them */
    ASSERT(!strcmp(srv_control_name(SRV_CTL_PAUSE), "pause"));
    ASSERT(!strcmp(srv_control_name(SRV_CTL_SEEK), "seek"));
    ASSERT(srv_control_name(0) == NULL);
    unsigned set = SRV_CTL_BIT(SRV_CTL_PAUSE) | SRV_CTL_BIT(SRV_CTL_SPEED);
    ASSERT((set & SRV_CTL_BIT(SRV_CTL_SEEK)) == 0 && (set & SRV_CTL_BIT(SRV_CTL_SPEED)) != 0);
    printf("ok\n");
    return 0;
}
