/* test_metrics.c - Prometheus text of the daemon's counters and histograms: cumulative buckets,
 * sums, the size query, and every drop reason present. */
#include "metrics.h"
#include "test.h"

#include <stdlib.h>
#include <string.h>

int main(void)
{
    static srv_metrics m;
    srv_metrics_init(&m);
    srv_metrics_count(&m.frames_in, 10);
    srv_metrics_count(&m.drops[SRV_DROP_CLIENT_SLOW], 3);
    srv_hist_observe(&m.latency, 50);      /* <= 100 us */
    srv_hist_observe(&m.latency, 1500);    /* <= 2 ms */
    srv_hist_observe(&m.latency, 5000000); /* +Inf */
    size_t need = srv_metrics_render(&m, 12.5, NULL, 0);
    ASSERT(need > 1000);
    char *buf = malloc(need + 1);
    ASSERT_INT_EQ(srv_metrics_render(&m, 12.5, buf, need + 1), need);
    ASSERT_INT_EQ(strlen(buf), need);
    ASSERT(strstr(buf, "\nmeshsteer_frames_in_total 10\n"));
    ASSERT(strstr(buf, "meshsteer_drops_total{reason=\"client_slow\"} 3\n"));
    ASSERT(strstr(buf, "meshsteer_drops_total{reason=\"synth_busy\"} 0\n"));
    ASSERT(strstr(buf, "meshsteer_latency_seconds_bucket{le=\"0.0001\"} 1\n"));
    ASSERT(strstr(buf, "meshsteer_latency_seconds_bucket{le=\"0.002\"} 2\n"));
    ASSERT(strstr(buf, "meshsteer_latency_seconds_bucket{le=\"1\"} 2\n"));
    ASSERT(strstr(buf, "meshsteer_latency_seconds_bucket{le=\"+Inf\"} 3\n"));
    ASSERT(strstr(buf, "meshsteer_latency_seconds_count 3\n"));
    ASSERT(strstr(buf, "meshsteer_latency_seconds_sum 5.001550\n"));
    ASSERT(strstr(buf, "# TYPE meshsteer_clients gauge\n"));
    ASSERT(strstr(buf, "meshsteer_uptime_seconds 12.500\n"));
    ASSERT(!strstr(buf, "meshsteer_osc_")); /* no osc: source */
    /* every sample line is "name[{labels}] value" */
    for (char *line = strtok(buf, "\n"); line; line = strtok(NULL, "\n"))
        if (line[0] != '#')
            ASSERT(strchr(line, ' ') && strncmp(line, "meshsteer_", 10) == 0);
    /* the osc: source's counters only when the source is one */
    {
        static srv_metrics mo;
        srv_metrics_init(&mo);
        atomic_store(&mo.osc.present, 1);
        srv_metrics_set(&mo.osc.packets, 7);
        srv_metrics_set(&mo.osc.malformed, 2);
        srv_metrics_set(&mo.osc.malformed, 3); /* a mirror: the source's total, not an increment */
        srv_metrics_set(&mo.osc.coalesced, 1);
        size_t on = srv_metrics_render(&mo, 1, NULL, 0);
        char *ob = malloc(on + 1);
        ASSERT(ob);
        srv_metrics_render(&mo, 1, ob, on + 1);
        ASSERT(strstr(ob, "# TYPE meshsteer_osc_packets_total counter\nmeshsteer_osc_packets_total 7\n"));
        ASSERT(strstr(ob, "\nmeshsteer_osc_malformed_total 3\n"));
        ASSERT(strstr(ob, "\nmeshsteer_osc_messages_total 0\n"));
        ASSERT(strstr(ob, "\nmeshsteer_osc_bad_messages_total 0\n"));
        ASSERT(strstr(ob, "\nmeshsteer_osc_unknown_names_total 0\n"));
        ASSERT(strstr(ob, "\nmeshsteer_osc_ignored_total 0\n"));
        ASSERT(strstr(ob, "\nmeshsteer_osc_frames_total 0\n"));
        ASSERT(strstr(ob, "\nmeshsteer_osc_coalesced_total 1\n"));
        free(ob);
    }
    /* a short buffer is truncated, NUL-terminated, and the full size is reported */
    char small[64];
    ASSERT_INT_EQ(srv_metrics_render(&m, 12.5, small, sizeof small), need);
    ASSERT_INT_EQ(strlen(small), sizeof small - 1);
    free(buf);
    printf("ok\n");
    return 0;
}
