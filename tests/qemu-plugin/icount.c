/*
 * icount: an exact guest-instruction counter for QEMU TCG (plugin API version 1, QEMU >= 4.2).
 *
 * Counts every executed guest instruction with an inline add (no helper call), and each time the
 * first instruction at one of the marker addresses is about to execute, writes
 * `mark <index> <instructions so far>`; at exit, `total <instructions>`.
 *
 *   qemu-system-arm ... -plugin ./icount.so,out=marks.txt,mark=0x1234,mark=0x1240
 *
 * With `profile=FILE` it also counts executions per instruction address (one more inline add per
 * instruction, into a hash table) and writes `<address> <count>` lines to FILE at exit, for
 * `llvm-addr2line` to attribute to source lines. `window=A:B` limits the profile to what runs between
 * the A-th and the B-th marker hit (counted from 0 over all markers), e.g. one phase of one frame.
 *
 * Debian ships neither qemu-plugin.h nor libglib2.0-dev, so the few API symbols used are declared
 * here (their prototypes in QEMU 7.2's include/qemu/qemu-plugin.h); QEMU resolves them when it loads
 * the plugin. Build: gcc -O2 -shared -fPIC -o icount.so icount.c
 * Single vCPU (Cortex-M), so a plain counter suffices.
 */
#include <inttypes.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define EXPORT __attribute__((visibility("default")))

typedef uint64_t qemu_plugin_id_t;
typedef struct {
    const char *target_name;
    struct { int min; int cur; } version;
    bool system_emulation;
    union { struct { int smp_vcpus; int max_vcpus; } system; };
} qemu_info_t;
struct qemu_plugin_tb;
struct qemu_plugin_insn;
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS, QEMU_PLUGIN_CB_R_REGS, QEMU_PLUGIN_CB_RW_REGS };
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb *tb);
typedef void (*qemu_plugin_vcpu_udata_cb_t)(unsigned int vcpu_index, void *userdata);
typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t id, void *userdata);

extern void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id,
                                                  qemu_plugin_vcpu_tb_trans_cb_t cb);
extern size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
extern struct qemu_plugin_insn *qemu_plugin_tb_get_insn(const struct qemu_plugin_tb *tb, size_t idx);
extern uint64_t qemu_plugin_insn_vaddr(const struct qemu_plugin_insn *insn);
extern void qemu_plugin_register_vcpu_insn_exec_inline(struct qemu_plugin_insn *insn,
                                                       enum qemu_plugin_op op, void *ptr,
                                                       uint64_t imm);
extern void qemu_plugin_register_vcpu_insn_exec_cb(struct qemu_plugin_insn *insn,
                                                   qemu_plugin_vcpu_udata_cb_t cb,
                                                   enum qemu_plugin_cb_flags flags,
                                                   void *userdata);
extern void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, qemu_plugin_udata_cb_t cb,
                                           void *userdata);

EXPORT int qemu_plugin_version = 1;

#define MAX_MARKS 16
static uint64_t insns;
static uint64_t marks[MAX_MARKS];
static size_t n_marks;
static FILE *out;

/* Per-address counters for profile=FILE: open addressing, never resized (the firmware's code is
 * small); a full table stops profiling new addresses and says so at exit. */
#define PROFILE_SLOTS (1u << 18)
struct slot {
    uint64_t pc;
    uint64_t count;
};
static struct slot *profile;
static const char *profile_path;
static bool profile_full;
/* Profile window in marker hits, and the counts at its start and end (snapshots of the table). */
static uint64_t window_from, window_to = UINT64_MAX, hits;
static uint64_t *window_start, *window_end;

static uint64_t *profile_counter(uint64_t pc)
{
    uint64_t h = (pc >> 1) * 0x9E3779B97F4A7C15ull;
    for (size_t i = 0; i < PROFILE_SLOTS; i++) {
        struct slot *s = &profile[(h + i) & (PROFILE_SLOTS - 1)];
        if (s->pc == pc + 1) {
            return &s->count;
        }
        if (s->pc == 0) {
            s->pc = pc + 1; /* +1: address 0 is a valid pc, slot pc 0 means empty */
            return &s->count;
        }
    }
    profile_full = true;
    return NULL;
}

static void snapshot(uint64_t **into)
{
    if (*into == NULL) {
        *into = calloc(PROFILE_SLOTS, sizeof **into);
        if (*into == NULL) {
            perror("icount: profile window");
            return;
        }
    }
    for (size_t i = 0; i < PROFILE_SLOTS; i++) {
        (*into)[i] = profile[i].count;
    }
}

static void on_mark(unsigned int vcpu, void *index)
{
    (void)vcpu;
    fprintf(out, "mark %zu %" PRIu64 "\n", (size_t)(uintptr_t)index, insns);
    if (profile != NULL && hits == window_from) {
        snapshot(&window_start);
    }
    if (profile != NULL && hits == window_to) {
        snapshot(&window_end);
    }
    hits++;
}

static void on_translate(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    (void)id;
    size_t n = qemu_plugin_tb_n_insns(tb);
    for (size_t i = 0; i < n; i++) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(tb, i);
        uint64_t pc = qemu_plugin_insn_vaddr(insn);
        for (size_t m = 0; m < n_marks; m++) {
            if (pc == marks[m]) {
                /* Registered before the add: the count excludes the marker instruction itself. */
                qemu_plugin_register_vcpu_insn_exec_cb(insn, on_mark, QEMU_PLUGIN_CB_NO_REGS,
                                                       (void *)(uintptr_t)m);
            }
        }
        qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, &insns, 1);
        if (profile != NULL) {
            uint64_t *c = profile_counter(pc);
            if (c != NULL) {
                qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, c, 1);
            }
        }
    }
}

static void at_exit(qemu_plugin_id_t id, void *userdata)
{
    (void)id;
    (void)userdata;
    fprintf(out, "total %" PRIu64 "\n", insns);
    fflush(out);
    if (out != stderr) {
        fclose(out);
    }
    if (profile != NULL) {
        FILE *f = fopen(profile_path, "w");
        if (f == NULL) {
            perror(profile_path);
            return;
        }
        if (profile_full) {
            fprintf(stderr, "icount: profile table full, some addresses not profiled\n");
        }
        if (window_to != UINT64_MAX && window_end == NULL) {
            fprintf(stderr, "icount: the profile window's end, marker hit %" PRIu64
                            ", never came (%" PRIu64 " hits)\n", window_to, hits);
        }
        for (size_t i = 0; i < PROFILE_SLOTS; i++) {
            uint64_t end = window_end != NULL ? window_end[i] : profile[i].count;
            uint64_t start = window_start != NULL ? window_start[i] : 0;
            if (profile[i].pc != 0 && end > start) {
                fprintf(f, "0x%08" PRIx64 " %" PRIu64 "\n", profile[i].pc - 1, end - start);
            }
        }
        fclose(f);
    }
}

EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv)
{
    (void)info;
    out = stderr;
    for (int i = 0; i < argc; i++) {
        const char *arg = argv[i];
        if (strncmp(arg, "mark=", 5) == 0 && n_marks < MAX_MARKS) {
            /* Thumb symbols have bit 0 set; instruction addresses do not. */
            marks[n_marks++] = strtoull(arg + 5, NULL, 0) & ~(uint64_t)1;
        } else if (strncmp(arg, "profile=", 8) == 0) {
            profile_path = arg + 8;
            profile = calloc(PROFILE_SLOTS, sizeof *profile);
            if (profile == NULL) {
                perror("icount: profile table");
                return -1;
            }
        } else if (strncmp(arg, "window=", 7) == 0) {
            char *colon;
            window_from = strtoull(arg + 7, &colon, 0);
            if (*colon != ':') {
                fprintf(stderr, "icount: window=FROM:TO, not %s\n", arg);
                return -1;
            }
            window_to = strtoull(colon + 1, NULL, 0);
        } else if (strncmp(arg, "out=", 4) == 0) {
            out = fopen(arg + 4, "w");
            if (out == NULL) {
                perror(arg + 4);
                return -1;
            }
        } else {
            fprintf(stderr, "icount: unknown argument %s (want out=FILE, mark=ADDR, profile=FILE, window=A:B)\n", arg);
            return -1;
        }
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_translate);
    qemu_plugin_register_atexit_cb(id, at_exit, NULL);
    return 0;
}
