#!/usr/bin/env python3
"""Where the instructions of one mcu-bench item go (a profiler for the emulated Cortex-M4).

    scripts/mcu-profile.py control_step.paper_xy [--wrapper control_step] [--top 25]

Builds mcu-bench with MCU_BENCH_ONLY=<item> (only that item runs), runs it in QEMU
netduinoplus2 with one instruction per translation block and an execution trace
(`-singlestep -d exec,nochain`), keeps only the instructions executed inside the bench's
`#[inline(never)]` `timed` wrapper of the item (from its entry until control is back in the caller),
and attributes each to its function (ELF symbol) and to its innermost source line
(`llvm-objdump -d -l`, release builds carry debug info). Prints instructions per call.
Honors CARGO_TARGET_DIR.
"""
import argparse
import collections
import functools
import glob
import os
import re
import subprocess
import sys
import tempfile

TARGET = "thumbv7em-none-eabihf"


def llvm(tool):
    sysroot = subprocess.check_output(["rustc", "--print", "sysroot"], text=True).strip()
    hits = glob.glob(os.path.join(sysroot, "lib/rustlib/*/bin", tool))
    if not hits:
        sys.exit(f"{tool} not found: rustup component add llvm-tools")
    return hits[0]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("item")
    ap.add_argument("--wrapper", default="timed",
                    help="function whose calls are profiled (default: the bench's `timed`)")
    ap.add_argument("--top", type=int, default=25)
    ap.add_argument("--lines-of", default="",
                    help="count source lines only for instructions of functions whose "
                         "(mangled) name contains this")
    ap.add_argument("--inclusive", action="store_true",
                    help="also count, per function, the instructions executed in it or in code "
                         "inlined into it (inline frames from llvm-symbolizer)")
    ap.add_argument("--mnemonics", action="store_true",
                    help="also count the executed instructions by mnemonic (vldr, vmul, b, ...)")
    ap.add_argument("--callers", default="memcpy",
                    help="also split the instructions of functions whose name contains this "
                         "by the function they were entered from and the source line of the call "
                         "(default: memcpy)")
    a = ap.parse_args()
    wrapper = a.wrapper
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    tdir = os.environ.get("CARGO_TARGET_DIR", os.path.join(root, "target"))
    env = dict(os.environ, MCU_BENCH_ONLY=a.item)
    subprocess.check_call(["cargo", "build", "-q", "-p", "mcu-bench", "--release",
                           "--target", TARGET], cwd=root, env=env)
    elf = os.path.join(tdir, TARGET, "release", "mcu-bench")

    # Address -> innermost source line, from the disassembly with line info.
    dis = subprocess.check_output([llvm("llvm-objdump"), "-d", "-l", "--no-show-raw-insn",
                                   elf], text=True)
    line_of = {}
    mnem_of = {}
    cur = "?"
    for ln in dis.splitlines():
        m = re.match(r"^; (/\S+:\d+)", ln)
        if m:
            cur = m.group(1)
            for pre in (root + "/", os.path.expanduser("~/.cargo/registry/src/")):
                cur = cur.replace(pre, "")
            cur = re.sub(r"^index\.crates\.io-[0-9a-f]+/", "", cur)
            cur = re.sub(r"^/rustc/[0-9a-f]+/library/", "std:", cur)
            continue
        m = re.match(r"^([0-9a-f]+) <", ln)
        if m:
            cur = "?"
            continue
        m = re.match(r"^\s*([0-9a-f]+):\s+(\S+)", ln)
        if m:
            line_of[int(m.group(1), 16)] = cur
            mnem_of[int(m.group(1), 16)] = m.group(2)

    with tempfile.TemporaryDirectory() as td:
        log = os.path.join(td, "trace.log")
        subprocess.run(["timeout", "300", "qemu-system-arm", "-M", "netduinoplus2", "-nographic",
                        "-monitor", "none", "-semihosting-config", "enable=on,target=native",
                        "-singlestep", "-d", "exec,nochain", "-D", log, "-kernel", elf],
                       stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, check=True)
        by_fn = collections.Counter()
        by_line = collections.Counter()
        calls = 0
        inside = False
        caller = None
        pat = re.compile(r"\[[0-9a-f]+/([0-9a-f]+)/[0-9a-f]+/[0-9a-f]+\] (\S+)")
        wrap_re = re.compile(r"mcu_bench\d*bench\d*" + re.escape(wrapper) + r"\d*h|"
                             r"bench::" + re.escape(wrapper) + "::|"
                             r"\d" + re.escape(wrapper) + r"17h")
        by_caller = collections.Counter()
        by_mnem = collections.Counter()
        by_pc = collections.Counter()
        callee_from = None
        prev_pc = None
        prev_sym = None
        with open(log, errors="replace") as f:
            for ln in f:
                m = pat.search(ln)
                if not m:
                    continue
                pc, sym = int(m.group(1), 16), m.group(2)
                if not inside and wrap_re.search(sym) and prev_sym != sym:
                    inside, caller, calls = True, prev_sym, calls + 1
                elif inside and sym == caller:
                    inside = False
                if inside:
                    by_fn[demangle(sym)] += 1
                    if a.inclusive:
                        by_pc[pc] += 1
                    if a.mnemonics:
                        by_mnem[mnem_of.get(pc, "?")] += 1
                    if a.lines_of in sym:
                        by_line[line_of.get(pc, "?")] += 1
                    if a.callers and a.callers in sym:
                        if prev_sym is not None and a.callers not in prev_sym:
                            callee_from = (demangle(prev_sym or "?"), line_of.get(prev_pc, "?"))
                        by_caller[callee_from] += 1
                prev_sym = sym
                prev_pc = pc
    if calls == 0:
        sys.exit(f"no call of the wrapper `{wrapper}` seen")
    total = sum(by_fn.values())
    print(f"{a.item}: {calls} calls, {total / calls:.1f} instructions per call "
          f"(trace, incl. call/return of the wrapper)")
    print("\nby function (instructions per call, inlined code counts in its caller):")
    for k, v in by_fn.most_common(a.top):
        print(f"  {v / calls:8.1f}  {k}")
    if by_caller:
        print(f"\n`{a.callers}` by where it was entered from (instructions per call):")
        for (fn, line), v in by_caller.most_common(a.top):
            print(f"  {v / calls:8.1f}  {fn}  ({line})")
    if by_pc:
        incl = inclusive(elf, by_pc)
        print("\ninclusive, by (inlined) function (instructions per call, callees included):")
        for k, v in incl.most_common(a.top):
            print(f"  {v / calls:8.1f}  {k}")
    if by_mnem:
        print("\nby mnemonic (instructions per call):")
        for k, v in by_mnem.most_common(a.top):
            print(f"  {v / calls:8.1f}  {k}")
    print("\nby innermost source line (instructions per call):")
    for k, v in by_line.most_common(a.top):
        print(f"  {v / calls:8.1f}  {k}")


def inclusive(elf, by_pc):
    """Per function, the executed instructions at addresses whose inline stack contains it."""
    pcs = sorted(by_pc)
    out = subprocess.run(["llvm-symbolizer", "--inlining", "--demangle", "--obj=" + elf],
                         input="".join(f"0x{pc:x}\n" for pc in pcs), text=True,
                         capture_output=True, check=True).stdout
    blocks = out.strip("\n").split("\n\n")
    incl = collections.Counter()
    for pc, blk in zip(pcs, blocks):
        lines = blk.splitlines()
        names = set()
        for fn in lines[0::2]:
            # llvm-symbolizer leaves Rust's legacy escapes (`_$LT$impl$u20$...$GT$`).
            fn = re.sub(r"::h[0-9a-f]{16}$", "", fn).replace("_$LT$", "<")
            for esc, ch in (("$LT$", "<"), ("$GT$", ">"), ("$u20$", " "), ("$u7b$", "{"),
                            ("$u7d$", "}"), ("$C$", ","), ("..", "::")):
                fn = fn.replace(esc, ch)
            names.add(fn)
        for n in names:
            incl[n] += by_pc[pc]
    return incl


@functools.lru_cache(maxsize=None)
def demangle(sym):
    try:
        return subprocess.check_output(["rustfilt"], input=sym, text=True).strip()
    except OSError:
        s = re.sub(r"17h[0-9a-f]{16}E$", "", sym)
        s = re.sub(r"^_ZN", "", s)
        parts = []
        while s:
            m = re.match(r"(\d+)", s)
            if not m:
                break
            n = int(m.group(1))
            s = s[len(m.group(1)):]
            parts.append(s[:n])
            s = s[n:]
        out = "::".join(parts) if parts else sym
        return out.replace("$LT$", "<").replace("$GT$", ">").replace("$u20$", " ") \
            .replace("..", "::").replace("$C$", ",")


if __name__ == "__main__":
    main()
