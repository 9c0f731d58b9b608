#!/usr/bin/env python3
"""Cycles per frame on a Cortex-A72 model, from the blocks the aarch64 binary ran (qemu).

Input: the blocks= and out= files of scripts/qemu_insn_stages.c for one replay (each translated
block that ran while the pipeline was active: address, instructions, runs, load misses, words), and
the binary's `nm -C -S` listing for per-function figures. Used by scripts/instructions_aarch64.sh
--cycles; the model and its limits are in docs/performance.md ("Cycles on a Cortex-A72 model").

Core cycles: every block's instruction words are disassembled (llvm-mc) and handed to llvm-mca
(-mcpu=cortex-a72: LLVM's Cortex-A57 pipeline description, which it uses for the A72) as one code
region; its steady-state cycles per iteration (100 iterations back to back) times the block's runs,
summed. That is the basic-block throughput model: perfect caches, perfect branch prediction, each
block overlapped with copies of itself instead of its real neighbours. A store that updates its
base register is modelled as the store and an add (split_writeback). The model charges a double
division or square root 32 cycles and does not pipeline them (A57 figures; the A72 has a faster
radix-16 divider), so their count is printed apart. Total Cycles / 100 includes the pipeline's
fill and drain once per 100 iterations (small).
Memory: the loads that missed the simulated L1 (and L2) during the pipeline, from the counts file,
priced at a stated latency each, without any overlap: the upper bound. The middle figure prices
only the irregular misses (those no constant stride of the same instruction explains, which a
stride prefetcher would not have fetched ahead). Out-of-order execution hides part of even those.
"""
import argparse
import bisect
import collections
import re
import subprocess
import sys


def read_blocks(path):
    """(address, words) -> [runs, load L1, L2, irregular L2 misses], merged over retranslations."""
    blocks = collections.OrderedDict()
    with open(path) as f:
        for line_no, line in enumerate(f, 1):
            fields = line.split()
            if len(fields) < 7 or fields[0] != "block" or len(fields) - 7 != int(fields[2]):
                sys.exit(f"cycle_model: {path}:{line_no}: not a block line: {line.strip()[:80]}")
            key = (int(fields[1], 16), tuple(fields[7:]))
            entry = blocks.setdefault(key, [0, 0, 0, 0])
            for k in range(4):
                entry[k] += int(fields[3 + k])
    return blocks


def read_counts(path):
    counts = {}
    with open(path) as f:
        for line in f:
            fields = line.split()
            if len(fields) == 3:
                counts[(fields[0], fields[1])] = int(fields[2])
    return counts


def disassemble(words, mcpu):
    """word (8 hex digits) -> assembly text; words llvm-mc cannot decode are left out."""
    text = "\n".join(" ".join("0x" + w[i:i + 2] for i in (6, 4, 2, 0)) for w in words)
    run = subprocess.run(["llvm-mc-14", "--disassemble", "-triple=aarch64", f"-mcpu={mcpu}", "--show-encoding"],
                         input=text, capture_output=True, text=True, check=False)
    asm = {}
    pattern = re.compile(r"^\s*(.*?)\s*// encoding: \[0x(..),0x(..),0x(..),0x(..)\]")
    for line in run.stdout.splitlines():
        m = pattern.match(line)
        if m:
            asm[m.group(5) + m.group(4) + m.group(3) + m.group(2)] = m.group(1)
    return asm


WRITEBACK_STORE = re.compile(r"^(st\w+)\s+(.*), \[(\w+)(?:, (#-?\w+))?\](!?)(?:, (#-?\w+|x\d+))?$")


def split_writeback(line):
    """A store that updates its base register, as the store and a separate add.

    llvm-mca issues an instruction as a whole, so it would delay the base register's new value
    until the stored data is ready, and chain a loop's iterations through it; the core computes
    the address in a uop of its own (the A57 model already gives these stores several uops)."""
    m = WRITEBACK_STORE.match(line)
    if m is None or (m.group(5) != "!" and m.group(6) is None):
        return [line]
    op, regs, base, pre_imm, _, post = m.groups()
    step = pre_imm if m.group(5) == "!" else post

    def add(amount):
        if amount.startswith("#-"):
            return f"sub {base}, {base}, #{amount[2:]}"
        return f"add {base}, {base}, {amount}"
    if m.group(5) == "!":
        return [add(step), f"{op} {regs}, [{base}]"]
    return [f"{op} {regs}, [{base}]", add(step)]


def mca_cycles(regions, mcpu, iterations):
    """[(name, [asm lines])] -> {name: cycles per iteration}."""
    source = []
    for name, lines in regions:
        source.append(f"# LLVM-MCA-BEGIN {name}")
        source.extend(lines)
        source.append("# LLVM-MCA-END")
    run = subprocess.run(["llvm-mca-14", "-mtriple=aarch64", f"-mcpu={mcpu}", f"-iterations={iterations}",
                          "-resource-pressure=0", "-instruction-info=0", "-"],
                         input="\n".join(source) + "\n", capture_output=True, text=True, check=False)
    if run.returncode != 0:
        sys.exit(f"cycle_model: llvm-mca failed: {run.stderr.strip()[:400]}")
    cycles = {}
    name = None
    for line in run.stdout.splitlines():
        if line.startswith("[") and "Code Region - " in line:
            name = line.split("Code Region - ", 1)[1].strip()
        elif line.startswith("Total Cycles:") and name is not None:
            cycles[name] = int(line.split(":")[1]) / iterations
    return cycles


def function_namer(nm_path):
    syms = []
    with open(nm_path) as f:
        for line in f:
            fields = line.split(None, 3)
            if len(fields) == 4 and fields[2] in "tTwW":
                syms.append((int(fields[0], 16), int(fields[1], 16), fields[3].strip()))
    syms.sort()
    starts = [s[0] for s in syms]

    def name(addr):
        i = bisect.bisect_right(starts, addr) - 1
        if i >= 0 and addr < syms[i][0] + syms[i][1]:
            return re.sub(r"\(.*", "", syms[i][2].replace("(anonymous namespace)", "{anon}"))
        return "(C library, other)"
    return name


def self_test(mcpu):
    """The rewriting and llvm-mca's answers on blocks whose costs are known in kind."""
    cases = {
        "str\tq0, [x14], #16": ["str q0, [x14]", "add x14, x14, #16"],
        "stp\tx29, x30, [sp, #-48]!": ["sub sp, sp, #48", "stp x29, x30, [sp]"],
        "st4\t{ v0.16b, v1.16b, v2.16b, v3.16b }, [x0], x2": ["st4 { v0.16b, v1.16b, v2.16b, v3.16b }, [x0]",
                                                             "add x0, x0, x2"],
        "str\td0, [x1, #8]": ["str\td0, [x1, #8]"],
        "ldr\tq0, [x1], #16": ["ldr\tq0, [x1], #16"],
    }
    for line, want in cases.items():
        got = split_writeback(line)
        if got != want:
            sys.exit(f"cycle_model: self-test: split_writeback({line!r}) = {got}, expected {want}")
    asm = disassemble(["1e620820", "1e621820"], mcpu)  # fmul d0, d1, d2; fdiv d0, d1, d2
    if sorted(asm.values()) != ["fdiv\td0, d1, d2", "fmul\td0, d1, d2"]:
        sys.exit(f"cycle_model: self-test: llvm-mc disassembled {asm}")
    c = mca_cycles([("independent", ["fmul d0, d1, d2", "fmul d3, d4, d5"]),
                    ("chained", ["fmul d0, d0, d2", "fmul d0, d0, d5"]),
                    ("divide", ["fdiv d0, d1, d2"]),
                    ("store_loop", ["ldr q0, [x14]", "fadd v0.2d, v0.2d, v1.2d", "fadd v0.2d, v0.2d, v1.2d"]
                     + split_writeback("str\tq0, [x14], #16"))], mcpu, 100)
    # Two independent multiplies issue together; a chain pays the latency; a divide is not
    # pipelined; a loop whose store bumps the pointer does not wait for the stored value.
    ok = (c["independent"] < c["chained"] and c["divide"] > 4 * c["independent"]
          and c["store_loop"] < c["chained"])
    if not ok:
        sys.exit(f"cycle_model: self-test: implausible llvm-mca cycles {c}")
    print(f"cycle_model: self-test passed ({c})")


def main():
    if "--self-test" in sys.argv[1:]:
        self_test("cortex-a72")
        return
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("blocks")
    ap.add_argument("counts")
    ap.add_argument("--frames", type=int, required=True)
    ap.add_argument("--nm", help="nm -C -S --defined-only of the binary: per-function figures")
    ap.add_argument("--mcpu", default="cortex-a72")
    ap.add_argument("--ghz", type=float, default=1.5, help="clock for the milliseconds (Raspberry Pi 4: 1.5)")
    ap.add_argument("--l2-cycles", type=float, default=21.0, help="extra cycles of a load served by L2")
    ap.add_argument("--dram-cycles", type=float, default=200.0, help="extra cycles of a load served by DRAM")
    ap.add_argument("--top", type=int, default=12)
    args = ap.parse_args()
    if args.frames <= 0:
        sys.exit("cycle_model: --frames must be positive")

    blocks = read_blocks(args.blocks)
    counts = read_counts(args.counts)
    asm = disassemble(sorted({w for key in blocks for w in key[1]}), args.mcpu)
    regions, unmodelled_insns, names = [], 0, {}
    for index, (key, entry) in enumerate(blocks.items()):
        lines = [asm.get(w) for w in key[1]]
        if any(line is None for line in lines):
            unmodelled_insns += entry[0] * len(key[1])
            continue
        names[key] = f"b{index}"
        regions.append((f"b{index}", [part for line in lines for part in split_writeback(line)]))
    per_block = mca_cycles(regions, args.mcpu, 100)
    lost = [name for name, _ in regions if name not in per_block]
    if lost:
        sys.exit(f"cycle_model: llvm-mca gave no cycles for {len(lost)} of {len(regions)} blocks (e.g. {lost[0]})")

    name_of = function_namer(args.nm) if args.nm else (lambda addr: "-")
    insns = cycles = 0.0
    by_fn = collections.defaultdict(lambda: [0.0, 0.0, 0, 0, 0])
    divides = 0
    for key, entry in blocks.items():
        n = entry[0] * len(key[1])
        # An undecodable block (none expected with -cpu cortex-a72) counts one cycle per instruction.
        c = entry[0] * per_block[names[key]] if key in names else n
        insns += n
        cycles += c
        fn = by_fn[name_of(key[0])]
        fn[0] += n
        fn[1] += c
        fn[2] += entry[2]
        fn[3] += entry[3]
        # Divisions and square roots: not pipelined in the model (see the docstring), so listed.
        d = entry[0] * sum(1 for w in key[1] if asm.get(w, "").startswith(("fdiv", "fsqrt")))
        fn[4] += d
        divides += d
    if insns == 0 or cycles == 0:
        sys.exit(f"cycle_model: {args.blocks}: no block ran in the stage")
    f = args.frames
    l1_load = counts.get(("l1_misses", "load"), 0)
    l2_load = counts.get(("l2_misses", "load"), 0)
    stall = (l1_load - l2_load) * args.l2_cycles + l2_load * args.dram_cycles
    l1_irr = counts.get(("l1_misses", "irregular_load"), 0)
    l2_irr = counts.get(("l2_misses", "irregular_load"), 0)
    stall_irr = (l1_irr - l2_irr) * args.l2_cycles + l2_irr * args.dram_cycles
    ms = lambda c: c / f / (args.ghz * 1e6)
    print(f"instructions        {insns / f / 1e6:8.1f} M/frame  (pipeline stage, {len(blocks)} blocks, "
          f"{unmodelled_insns / max(insns, 1) * 100:.3f} % not decodable)")
    print(f"core cycles         {cycles / f / 1e6:8.1f} M/frame  IPC {insns / cycles:.2f}  "
          f"{ms(cycles):.1f} ms at {args.ghz} GHz")
    print(f"divisions, roots    {divides / f / 1e3:8.1f} k/frame (fdiv, fsqrt; not pipelined in the model: 32 cycles "
          f"a double, 64 a pair)")
    print(f"load misses         L1 {l1_load / f / 1e3:.0f} k/frame, L2 {l2_load / f / 1e3:.0f} k/frame "
          f"(+{args.l2_cycles:g} / +{args.dram_cycles:g} cycles each); irregular L1 {l1_irr / f / 1e3:.0f} k, "
          f"L2 {l2_irr / f / 1e3:.0f} k")
    print(f"with memory stalls  {cycles / f / 1e6:.1f} / {(cycles + stall_irr) / f / 1e6:.1f} / "
          f"{(cycles + stall) / f / 1e6:.1f} M cycles/frame  {ms(cycles):.1f} / {ms(cycles + stall_irr):.1f} / "
          f"{ms(cycles + stall):.1f} ms (no stall / irregular misses serialized / every miss serialized)")
    if args.nm:
        print(f"{'M instr':>8} {'M cycles':>9} {'IPC':>5} {'k L2 miss':>9} {'irregular':>9} {'k div':>6}  "
              "function (per frame)")
        for name, (n, c, m2, irr, d) in sorted(by_fn.items(), key=lambda kv: -kv[1][1])[:args.top]:
            print(f"{n / f / 1e6:8.2f} {c / f / 1e6:9.2f} {n / c:5.2f} {m2 / f / 1e3:9.1f} {irr / f / 1e3:9.1f} "
                  f"{d / f / 1e3:6.1f}  {name[:90]}")


if __name__ == "__main__":
    main()
