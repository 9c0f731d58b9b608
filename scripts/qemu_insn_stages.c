/* A qemu-user TCG plugin that counts the guest (aarch64) instructions a program executes: all of
 * them, and per stage the instructions executed while a given function is active, callees
 * included (what callgrind's --toggle-collect counts on x86). scripts/instructions_aarch64.sh
 * builds it against qemu 7.2's include/qemu/qemu-plugin.h and passes the functions' addresses.
 *
 * Arguments (-plugin lib.so,arg=value,...):
 *   out=PATH               where the counts go (text, one "key label value" per line)
 *   main=0xADDR            main's address in the ELF (nm): the load bias of a PIE is the
 *                          difference to where qemu runs it
 *   fn=LABEL:0xADDR:0xSIZE a function's entry and size (nm -S); functions with the same label
 *                          count into one stage
 *   blocks=PATH            also write, per translated block, how often it ran while the stage
 *                          block_stage=LABEL was active, with its instruction words (input of
 *                          scripts/cycle_model.py: basic-block throughput by llvm-mca)
 *   cache=L1:W1:L2:W2      also simulate a data cache of L1 bytes (W1 ways) and a unified L2 of L2
 *                          bytes (W2 ways), 64-byte lines, LRU, fed by every load and store of the
 *                          program; the accesses and misses of block_stage are written, the
 *                          load misses also split into strided ones (the same instruction's
 *                          last three executions accessed addresses equally many bytes apart: a
 *                          stride prefetcher would have fetched the line) and irregular ones. For
 *                          one thread only (the replay's --deterministic pipeline): the vCPUs
 *                          seen are written, and the script refuses the figures with more
 *
 * How a function's activity is followed without register access (the 7.2 API has none): a call
 * enters at the function's first instruction, which always starts a translation block (a branch
 * target). The call instruction executed last (BL or BLR, followed by a callback on each) is the
 * one that made it: the function is active until control comes back to the instruction after
 * it. That also holds when the function leaves by a tail call (its callee returns there) and when
 * it was entered by one (the tail caller's return address is the same). State per vCPU (qemu-user
 * runs one per guest thread). The script refuses the figures unless every entry came back. */
#include <inttypes.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <qemu-plugin.h>

QEMU_PLUGIN_EXPORT int qemu_plugin_version = QEMU_PLUGIN_VERSION;

enum { kMaxFns = 64, kMaxLabels = 8, kMaxVcpus = 64, kMaxDepth = 256 };

typedef struct {
  int label_index;
  uint64_t elf_addr, size;
} Function;

typedef struct {
  int label;
  uint64_t return_pc;
} Activation;

typedef struct {
  uint64_t total;                 /* every instruction of this vCPU */
  uint64_t in_stage[kMaxLabels];  /* instructions while the stage's functions are active */
  uint32_t active[kMaxLabels];    /* activations of the stage on the stack */
  uint64_t entries[kMaxLabels], returns[kMaxLabels];
  uint64_t last_call_pc;
  uint64_t execs; /* blocks run: tells a memory instruction's executions apart */
  Activation stack[kMaxDepth];
  int depth;
  uint64_t overflows;
} Vcpu;

/* What a translated block does when it runs: come back from the activations that return to its
 * first instruction, enter the functions it starts (a bit per label), count its instructions. */
typedef struct {
  uint64_t start_pc;
  uint32_t n_insns;
  uint32_t enter_mask;
  uint64_t stage_execs; /* runs while block_stage was active (blocks=) */
  uint32_t* words;      /* the instructions (blocks=) */
  uint64_t load_l1_misses, load_l2_misses, irregular_l2_misses; /* of its loads in block_stage (cache=) */
} BlockInfo;

/* One set-associative level: tags and last-use stamps, set-major. */
typedef struct {
  int sets, ways;
  uint64_t* tags;
  uint64_t* stamps;
  uint64_t clock;
} CacheLevel;

static Function fns[kMaxFns];
static int n_fns;
static char labels[kMaxLabels][32];
static int n_labels;
static uint64_t main_elf_addr;
static bool have_bias;
static int64_t load_bias;
static Vcpu vcpus[kMaxVcpus];
static const char* out_path;
static const char* blocks_path;
static const char* block_stage_name;
static int block_stage = -1;
static BlockInfo** blocks; /* every translation, for blocks= */
static size_t n_blocks, cap_blocks;
static pthread_mutex_t blocks_lock = PTHREAD_MUTEX_INITIALIZER;
static bool simulate_cache;
static CacheLevel l1, l2;
/* In block_stage, [0] loads, [1] stores: accesses (per cache line of each memory operation qemu
 * reports; it splits a pair or a 128-bit access into 8-byte ones), L1 misses, L2 misses; and the
 * loads' misses no stride explains. */
static uint64_t stage_accesses[2], stage_l1_misses[2], stage_l2_misses[2];
static uint64_t irregular_l1_misses, irregular_l2_misses;

/* A memory instruction: its block (per-block miss counts) and its address history (stride), one
 * address per execution (the first of the operations qemu reports for it). */
typedef struct {
  BlockInfo* block;
  uint64_t last_exec; /* Vcpu::execs of its last execution */
  uint64_t last_addr; /* first address of its last execution */
  int64_t stride;     /* bytes, between its last two executions */
  bool strided;       /* this execution's address continued the stride */
} MemInsn;

static uint32_t vcpus_seen;

static Vcpu* vcpu_of(unsigned index) { return &vcpus[index % kMaxVcpus]; }

static uint32_t word_of(const struct qemu_plugin_insn* insn) {
  uint32_t w = 0;
  if (qemu_plugin_insn_size(insn) == 4) memcpy(&w, qemu_plugin_insn_data(insn), 4);
  return w;
}

static void on_block(unsigned vcpu_index, void* udata) {
  const BlockInfo* b = (const BlockInfo*)udata;
  Vcpu* v = vcpu_of(vcpu_index);
  while (v->depth > 0 && v->stack[v->depth - 1].return_pc == b->start_pc) {
    const int l = v->stack[--v->depth].label;
    --v->active[l];
    ++v->returns[l];
  }
  for (int l = 0; b->enter_mask != 0 && l < n_labels; ++l) {
    if ((b->enter_mask & (1u << l)) == 0) continue;
    ++v->entries[l];
    if (v->depth == kMaxDepth) {
      ++v->overflows;
      continue;
    }
    v->stack[v->depth++] = (Activation){l, v->last_call_pc + 4};
    ++v->active[l];
  }
  v->total += b->n_insns;
  ++v->execs;
  for (int l = 0; l < n_labels; ++l) {
    if (v->active[l] > 0) v->in_stage[l] += b->n_insns;
  }
  if (block_stage >= 0 && v->active[block_stage] > 0) __atomic_fetch_add(&((BlockInfo*)udata)->stage_execs, 1, __ATOMIC_RELAXED);
}

static bool cache_init(CacheLevel* c, uint64_t bytes, int ways) {
  if (ways <= 0 || bytes < 64u * (uint64_t)ways) return false;
  c->ways = ways;
  c->sets = (int)(bytes / 64u / (uint64_t)ways);
  if ((c->sets & (c->sets - 1)) != 0) return false; /* the set index is a mask */
  c->tags = calloc((size_t)c->sets * (size_t)ways, sizeof *c->tags);
  c->stamps = calloc((size_t)c->sets * (size_t)ways, sizeof *c->stamps);
  return c->tags != NULL && c->stamps != NULL;
}

/* true on a hit; a miss fills the least recently used way. Tags are line + 1 (0: empty). */
static bool cache_access(CacheLevel* c, uint64_t line) {
  const size_t base = (size_t)(line & (uint64_t)(c->sets - 1)) * (size_t)c->ways;
  size_t victim = base;
  ++c->clock;
  for (size_t w = base; w < base + (size_t)c->ways; ++w) {
    if (c->tags[w] == line + 1) {
      c->stamps[w] = c->clock;
      return true;
    }
    if (c->stamps[w] < c->stamps[victim]) victim = w;
  }
  c->tags[victim] = line + 1;
  c->stamps[victim] = c->clock;
  return false;
}

static void access_line(uint64_t line, bool strided, bool in_stage, int store, MemInsn* m) {
  if (cache_access(&l1, line)) {
    if (in_stage) ++stage_accesses[store];
    return;
  }
  const bool l2_hit = cache_access(&l2, line);
  if (!in_stage) return;
  ++stage_accesses[store];
  ++stage_l1_misses[store];
  if (!l2_hit) ++stage_l2_misses[store];
  if (store == 0) {
    ++m->block->load_l1_misses;
    if (!l2_hit) ++m->block->load_l2_misses;
    if (!strided) {
      ++irregular_l1_misses;
      if (!l2_hit) {
        ++irregular_l2_misses;
        ++m->block->irregular_l2_misses;
      }
    }
  }
}

/* The replay's pipeline runs on one thread: one cache, no lock (a second thread would share it). */
static void on_mem(unsigned vcpu_index, qemu_plugin_meminfo_t info, uint64_t vaddr, void* udata) {
  const Vcpu* v = vcpu_of(vcpu_index);
  const bool in_stage = block_stage >= 0 && v->active[block_stage] > 0;
  const uint64_t size = 1u << qemu_plugin_mem_size_shift(info);
  const uint64_t first = vaddr >> 6, last = (vaddr + size - 1) >> 6;
  const int store = qemu_plugin_mem_is_store(info) ? 1 : 0;
  MemInsn* m = (MemInsn*)udata;
  if (m->last_exec != v->execs) {
    const int64_t stride = (int64_t)(vaddr - m->last_addr);
    m->strided = stride != 0 && stride == m->stride;
    m->stride = stride;
    m->last_addr = vaddr;
    m->last_exec = v->execs;
  }
  for (uint64_t line = first; line <= last; ++line) access_line(line, m->strided, in_stage, store, m);
}

static void remember_block(BlockInfo* info, struct qemu_plugin_tb* tb) {
  info->words = calloc(info->n_insns > 0 ? info->n_insns : 1, sizeof *info->words);
  for (uint32_t i = 0; i < info->n_insns; ++i) info->words[i] = word_of(qemu_plugin_tb_get_insn(tb, i));
  pthread_mutex_lock(&blocks_lock);
  if (n_blocks == cap_blocks) {
    cap_blocks = cap_blocks == 0 ? 4096 : 2 * cap_blocks;
    blocks = realloc(blocks, cap_blocks * sizeof *blocks);
  }
  blocks[n_blocks++] = info;
  pthread_mutex_unlock(&blocks_lock);
}

static void on_call(unsigned vcpu_index, void* udata) { vcpu_of(vcpu_index)->last_call_pc = (uint64_t)(uintptr_t)udata; }

static bool is_call(uint32_t w) {
  /* BL imm26; BLR Xn; BLRAA/BLRAAZ/BLRAB/BLRABZ (pointer authentication). */
  return (w & 0xfc000000u) == 0x94000000u || (w & 0xfffffc1fu) == 0xd63f0000u || (w & 0xfefff800u) == 0xd63f0800u;
}

static void learn_bias(struct qemu_plugin_tb* tb) {
  if (have_bias || qemu_plugin_tb_n_insns(tb) == 0) return;
  const char* sym = qemu_plugin_insn_symbol(qemu_plugin_tb_get_insn(tb, 0));
  /* main is entered by a call from the C library: its first block starts at its address. */
  if (sym != NULL && strcmp(sym, "main") == 0) {
    load_bias = (int64_t)(qemu_plugin_tb_vaddr(tb) - main_elf_addr);
    have_bias = true;
  }
}

static void on_translate(qemu_plugin_id_t id, struct qemu_plugin_tb* tb) {
  (void)id;
  learn_bias(tb);
  const size_t n = qemu_plugin_tb_n_insns(tb);
  BlockInfo* info = calloc(1, sizeof *info); /* lives as long as the block: never freed */
  info->start_pc = qemu_plugin_tb_vaddr(tb);
  info->n_insns = (uint32_t)n;
  for (int f = 0; have_bias && f < n_fns; ++f) {
    if (info->start_pc == fns[f].elf_addr + (uint64_t)load_bias) info->enter_mask |= 1u << fns[f].label_index;
  }
  if (blocks_path != NULL) remember_block(info, tb);
  qemu_plugin_register_vcpu_tb_exec_cb(tb, on_block, QEMU_PLUGIN_CB_NO_REGS, info);
  for (size_t i = 0; i < n; ++i) {
    struct qemu_plugin_insn* insn = qemu_plugin_tb_get_insn(tb, i);
    if (simulate_cache) {
      MemInsn* m = calloc(1, sizeof *m); /* lives as long as the block */
      m->block = info;
      qemu_plugin_register_vcpu_mem_cb(insn, on_mem, QEMU_PLUGIN_CB_NO_REGS, QEMU_PLUGIN_MEM_RW, m);
    }
    if (is_call(word_of(insn))) {
      qemu_plugin_register_vcpu_insn_exec_cb(insn, on_call, QEMU_PLUGIN_CB_NO_REGS,
                                             (void*)(uintptr_t)qemu_plugin_insn_vaddr(insn));
    }
  }
}

/* "block 0xELF_ADDR n_insns runs load_l1_misses load_l2_misses irregular_l2_misses word..." for each translation that ran in block_stage. */
static void write_blocks(void) {
  FILE* f = fopen(blocks_path, "w");
  if (f == NULL) {
    qemu_plugin_outs("qemu_insn_stages: cannot write the blocks (blocks=)\n");
    return;
  }
  for (size_t k = 0; k < n_blocks; ++k) {
    const BlockInfo* b = blocks[k];
    if (b->stage_execs == 0) continue;
    fprintf(f, "block 0x%" PRIx64 " %" PRIu32 " %" PRIu64 " %" PRIu64 " %" PRIu64 " %" PRIu64,
            b->start_pc - (uint64_t)load_bias, b->n_insns, b->stage_execs, b->load_l1_misses, b->load_l2_misses,
            b->irregular_l2_misses);
    for (uint32_t i = 0; i < b->n_insns; ++i) fprintf(f, " %08" PRIx32, b->words[i]);
    fputc('\n', f);
  }
  fclose(f);
}

static void on_vcpu_init(qemu_plugin_id_t id, unsigned int vcpu_index) {
  (void)id;
  (void)vcpu_index;
  __atomic_fetch_add(&vcpus_seen, 1, __ATOMIC_RELAXED);
}

static void write_counts(qemu_plugin_id_t id, void* udata) {
  (void)id;
  (void)udata;
  FILE* f = out_path != NULL ? fopen(out_path, "w") : NULL;
  if (f == NULL) {
    qemu_plugin_outs("qemu_insn_stages: cannot write the counts (out=)\n");
    return;
  }
  uint64_t total = 0, overflows = 0;
  for (int c = 0; c < kMaxVcpus; ++c) {
    total += vcpus[c].total;
    overflows += vcpus[c].overflows;
  }
  fprintf(f, "total - %" PRIu64 "\nbias_found - %d\nstack_overflows - %" PRIu64 "\nvcpus - %" PRIu32 "\n", total,
          have_bias ? 1 : 0, overflows, vcpus_seen);
  for (int l = 0; l < n_labels; ++l) {
    uint64_t in = 0, entries = 0, returns = 0;
    for (int c = 0; c < kMaxVcpus; ++c) {
      in += vcpus[c].in_stage[l];
      entries += vcpus[c].entries[l];
      returns += vcpus[c].returns[l];
    }
    fprintf(f, "stage %s %" PRIu64 "\nentries %s %" PRIu64 "\nreturns %s %" PRIu64 "\n", labels[l], in, labels[l],
            entries, labels[l], returns);
  }
  if (simulate_cache) {
    for (int k = 0; k < 2; ++k) {
      const char* kind = k == 0 ? "load" : "store";
      fprintf(f, "accesses %s %" PRIu64 "\nl1_misses %s %" PRIu64 "\nl2_misses %s %" PRIu64 "\n", kind, stage_accesses[k],
              kind, stage_l1_misses[k], kind, stage_l2_misses[k]);
    }
    fprintf(f, "l1_misses irregular_load %" PRIu64 "\nl2_misses irregular_load %" PRIu64 "\n", irregular_l1_misses,
            irregular_l2_misses);
  }
  fclose(f);
  if (blocks_path != NULL) write_blocks();
}

static int label_index_of(const char* label) {
  for (int l = 0; l < n_labels; ++l) {
    if (strcmp(labels[l], label) == 0) return l;
  }
  if (n_labels == kMaxLabels) return -1;
  snprintf(labels[n_labels], sizeof labels[0], "%s", label);
  return n_labels++;
}

static bool parse_fn(const char* value) {
  if (n_fns == kMaxFns) return false;
  Function* fn = &fns[n_fns];
  const char* colon = strchr(value, ':');
  char label[sizeof labels[0]];
  if (colon == NULL || colon == value || (size_t)(colon - value) >= sizeof label) return false;
  memcpy(label, value, (size_t)(colon - value));
  label[colon - value] = '\0';
  char* end = NULL;
  fn->elf_addr = strtoull(colon + 1, &end, 16);
  if (end == NULL || *end != ':') return false;
  fn->size = strtoull(end + 1, &end, 16);
  if (*end != '\0' || fn->size == 0) return false;
  fn->label_index = label_index_of(label);
  if (fn->label_index < 0) return false;
  ++n_fns;
  return true;
}

QEMU_PLUGIN_EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t* info, int argc, char** argv) {
  if (strcmp(info->target_name, "aarch64") != 0) {
    fprintf(stderr, "qemu_insn_stages: aarch64 guests only (this is %s)\n", info->target_name);
    return 1;
  }
  for (int i = 0; i < argc; ++i) {
    const char* a = argv[i];
    bool ok = true;
    if (strncmp(a, "out=", 4) == 0) {
      out_path = a + 4;
    } else if (strncmp(a, "main=", 5) == 0) {
      main_elf_addr = strtoull(a + 5, NULL, 16);
    } else if (strncmp(a, "fn=", 3) == 0) {
      ok = parse_fn(a + 3);
    } else if (strncmp(a, "blocks=", 7) == 0) {
      blocks_path = a + 7;
    } else if (strncmp(a, "block_stage=", 12) == 0) {
      block_stage_name = a + 12;
    } else if (strncmp(a, "cache=", 6) == 0) {
      unsigned long long b1 = 0, b2 = 0;
      int w1 = 0, w2 = 0;
      ok = sscanf(a + 6, "%llu:%d:%llu:%d", &b1, &w1, &b2, &w2) == 4 && cache_init(&l1, b1, w1) && cache_init(&l2, b2, w2);
      simulate_cache = ok;
    } else {
      ok = false;
    }
    if (!ok) {
      fprintf(stderr,
              "qemu_insn_stages: bad argument '%s' (out=PATH, main=0xADDR, fn=LABEL:0xADDR:0xSIZE, blocks=PATH, "
              "block_stage=LABEL, cache=L1BYTES:WAYS:L2BYTES:WAYS with power-of-two sets)\n",
              a);
      return 1;
    }
  }
  if (out_path == NULL || (n_fns > 0 && main_elf_addr == 0)) {
    fprintf(stderr, "qemu_insn_stages: needs out=PATH, and main=0xADDR with fn=\n");
    return 1;
  }
  if (block_stage_name != NULL) {
    for (int l = 0; l < n_labels; ++l) {
      if (strcmp(labels[l], block_stage_name) == 0) block_stage = l;
    }
  }
  if ((blocks_path != NULL || simulate_cache) && block_stage < 0) {
    fprintf(stderr, "qemu_insn_stages: blocks= and cache= need block_stage=LABEL, a label of fn=\n");
    return 1;
  }
  qemu_plugin_register_vcpu_init_cb(id, on_vcpu_init);
  qemu_plugin_register_vcpu_tb_trans_cb(id, on_translate);
  qemu_plugin_register_atexit_cb(id, write_counts, NULL);
  return 0;
}
