/* loadclient_nats.c - meshsteer-load's NATS transport (see loadclient.h): the frames as a viewer
 * subscribed through a NATS cluster gets them (docs/PROTOCOL.md, "NATS").
 *
 * Each subscriber is one libnats connection (its own TCP connection to a node, as each browser
 * would have) with one subscription. Messages are handed to the callbacks by libnats' shared
 * delivery pool (DELIVERY_THREADS threads for every subscription) instead of a thread per
 * subscription, and connections send as soon as they write (no flusher thread): so a few hundred
 * subscribers cost a few hundred reading threads, not three times that. The receipt time is taken
 * in the callback, so the latency includes this client's own queueing. */
#include "loadclient.h"

#include <nats/nats.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define DELIVERY_THREADS 4
#define URLS_MAX 16

typedef struct nsub {
    natsConnection *nc;
    natsSubscription *s;
    load_run *r;
    load_stats *st;
    atomic_uint_fast64_t bad; /* messages that are not frames */
} nsub;

static void on_frame(natsConnection *nc, natsSubscription *s, natsMsg *m, void *closure)
{
    (void)nc, (void)s;
    nsub *u = closure;
    uint64_t t = load_now_us();
    const unsigned char *h = (const unsigned char *)natsMsg_GetData(m);
    if (natsMsg_GetDataLength(m) >= LOAD_HEADER && !memcmp(h, "MSFR", 4))
        load_frame(u->r, u->st, h, (uint64_t)natsMsg_GetDataLength(m), t);
    else
        atomic_fetch_add(&u->bad, 1);
    natsMsg_Destroy(m);
}

/* The hello and topology by request-reply, as a late joiner gets them; 0 when both came. */
static int join(natsConnection *nc, const char *prefix)
{
    char subj[256];
    natsMsg *hello = NULL, *topo = NULL;
    snprintf(subj, sizeof subj, "%s.get.hello", prefix);
    natsStatus s = natsConnection_Request(&hello, nc, subj, "", 0, 10000);
    if (s == NATS_OK) {
        snprintf(subj, sizeof subj, "%s.get.topology", prefix);
        s = natsConnection_Request(&topo, nc, subj, "", 0, 10000);
    }
    int ok = s == NATS_OK && natsMsg_GetDataLength(hello) > 0 &&
             natsMsg_GetData(hello)[0] == '{' && natsMsg_GetDataLength(topo) >= LOAD_HEADER &&
             !memcmp(natsMsg_GetData(topo), "MSTO", 4);
    if (!ok)
        fprintf(stderr, "meshsteer-load: no hello and topology on %s.get.*: %s\n", prefix,
                s == NATS_OK ? "unexpected reply" : natsStatus_GetText(s));
    natsMsg_Destroy(hello);
    natsMsg_Destroy(topo);
    return ok ? 0 : -1;
}

static int open_sub(nsub *u, const char **urls, int nurls, int first, const char *subject,
                    const char *prefix)
{
    const char *order[URLS_MAX];
    for (int k = 0; k < nurls; k++)
        order[k] = urls[(first + k) % nurls];
    natsOptions *o = NULL;
    natsStatus s = natsOptions_Create(&o);
    if (s == NATS_OK)
        s = natsOptions_SetServers(o, order, nurls);
    if (s == NATS_OK)
        s = natsOptions_SetNoRandomize(o, true);
    if (s == NATS_OK)
        s = natsOptions_SetMaxReconnect(o, -1);
    if (s == NATS_OK)
        s = natsOptions_SetReconnectWait(o, 100);
    if (s == NATS_OK)
        s = natsOptions_SetSendAsap(o, true);
    if (s == NATS_OK)
        s = natsOptions_UseGlobalMessageDelivery(o, true);
    if (s == NATS_OK)
        s = natsConnection_Connect(&u->nc, o);
    natsOptions_Destroy(o);
    if (s == NATS_OK && join(u->nc, prefix))
        return -1;
    if (s == NATS_OK)
        s = natsConnection_Subscribe(&u->s, u->nc, subject, on_frame, u);
    if (s == NATS_OK) /* no frame limit per subscriber: a slow one is measured, not cut off */
        s = natsSubscription_SetPendingLimits(u->s, -1, 256 << 20);
    if (s == NATS_OK)
        s = natsConnection_Flush(u->nc);
    if (s != NATS_OK) {
        fprintf(stderr, "meshsteer-load: %s: %s\n", order[0], natsStatus_GetText(s));
        return -1;
    }
    return 0;
}

int load_nats_run(load_run *r, const char *urls, const char *prefix, int n, load_stats *st,
                  int *up)
{
    char store[4096];
    const char *list[URLS_MAX];
    int nurls = 0;
    if (strlen(urls) >= sizeof store) {
        fprintf(stderr, "meshsteer-load: --nats: list too long\n");
        return -1;
    }
    strcpy(store, urls);
    for (char *save = NULL, *u = strtok_r(store, ",", &save); u; u = strtok_r(NULL, ",", &save)) {
        if (nurls == URLS_MAX || strncmp(u, "nats://", 7)) {
            fprintf(stderr, "meshsteer-load: --nats: '%s': give up to %d nats://HOST:PORT URLs\n",
                    u, URLS_MAX);
            return -1;
        }
        list[nurls++] = u;
    }
    if (!nurls) {
        fprintf(stderr, "meshsteer-load: --nats: no URL\n");
        return -1;
    }
    char subject[256];
    snprintf(subject, sizeof subject, "%s.frames.%s", prefix, r->encoding);
    if (nats_SetMessageDeliveryPoolSize(DELIVERY_THREADS) != NATS_OK) {
        fprintf(stderr, "meshsteer-load: cannot start libnats\n");
        return -1;
    }
    nsub *s = calloc((size_t)n, sizeof *s);
    if (!s) {
        fprintf(stderr, "meshsteer-load: out of memory\n");
        return -1;
    }
    int joined = 0;
    for (int i = 0; i < n; i++) {
        s[i].r = r;
        s[i].st = &st[i];
        joined += open_sub(&s[i], list, nurls, i, subject, prefix) == 0;
    }
    for (uint64_t now = load_now_us(); now < r->t_end; now = load_now_us()) {
        uint64_t left = r->t_end - now, step = left < 50000 ? left : 50000;
        struct timespec ts = {0, (long)step * 1000L};
        nanosleep(&ts, NULL);
    }
    *up = 0;
    uint64_t bad = 0;
    for (int i = 0; i < n; i++) {
        *up += s[i].s && natsConnection_Status(s[i].nc) == NATS_CONN_STATUS_CONNECTED;
        natsSubscription_Destroy(s[i].s);
        natsConnection_Destroy(s[i].nc);
        bad += atomic_load(&s[i].bad);
    }
    nats_CloseAndWait(5000); /* every callback has returned: st is complete */
    free(s);
    if (bad)
        fprintf(stderr, "meshsteer-load: %llu messages on %s were not frames\n",
                (unsigned long long)bad, subject);
    return joined == n ? 0 : 1;
}
