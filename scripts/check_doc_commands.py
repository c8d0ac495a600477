#!/usr/bin/env python3
"""Checks that the README and docs/ say what runs: every command in their shell code blocks, and
every relative link.

    scripts/check_doc_commands.py [FILE.md ...] [--build DIR] [--timeout S] [--links-only] [--list]

Files: README.md and docs/*.md by default. Convention for fenced code blocks:

  ```sh              run: every command in it runs, in order, and must exit 0
  ```sh needs-data   run when ../shared/data holds the motion archives (skipped otherwise)
  ```sh no-run       shown, not run (trainings of hours, `make demo`, servers); its `mosyn`
                     options are still checked against `mosyn COMMAND --help`
  ```text, ```c ...  anything else: neither run nor checked

A command is one line, or several joined by a trailing backslash. Commands run with bash from the
repository root as seen through a scratch folder: a temporary directory holding a link to every
top-level entry of the repository (`build` pointing at --build, default $MOSYN_BUILD or ./build)
and `../shared` pointing at the repository's ../shared. What a command writes with a relative path
(`--out walks`) lands in that scratch folder and is deleted afterwards; the pages run one after
another, each in its own scratch folder, so a page's commands may use what its earlier commands
wrote. Each command has --timeout seconds (default 120, or $MOSYN_DOC_TIMEOUT); OMP_NUM_THREADS=1 and
OMP_WAIT_POLICY=passive.

Every `mosyn` command in a shell block (run or not) has its options checked against the help of
its subcommand, so a renamed option fails here. Relative Markdown links and images must point at
existing files, and a `#anchor` into a Markdown file at one of its headings.

Prints one line per failure as FILE:LINE: what, then a summary; exit code 0 when all passed, 1
otherwise. ctest runs it as `docs.commands` (tests/CMakeLists.txt).
"""
import argparse, glob, os, re, shutil, subprocess, sys, tempfile, time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHELLS = {"sh", "bash", "shell"}
FENCE = re.compile(r"^(\s*)(```+|~~~+)\s*([^`]*)$")


def blocks(path):
    """Yields (info_words, [(line_no, text)]) for each fenced code block of a Markdown file."""
    with open(path, encoding="utf-8") as f:
        lines = f.read().split("\n")
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        fence, info = m.group(2), m.group(3).split()
        body = []
        i += 1
        while i < len(lines) and not lines[i].strip().startswith(fence):
            body.append((i + 1, lines[i]))
            i += 1
        yield info, body
        i += 1


def commands(body):
    """Joins backslash-continued lines; yields (first line number, command) without comment lines."""
    current, start = [], None
    for no, text in body:
        if not current and (not text.strip() or text.lstrip().startswith("#")):
            continue
        if not current:
            start = no
        if text.rstrip().endswith("\\"):
            current.append(text.rstrip()[:-1])
            continue
        current.append(text)
        yield start, " ".join(part.strip() for part in current)
        current = []
    if current:
        yield start, " ".join(part.strip() for part in current)


def strip_comment(command):
    """The command without a trailing shell comment (a # after whitespace, outside quotes)."""
    quote = None
    for k, c in enumerate(command):
        if quote:
            if c == quote:
                quote = None
        elif c in "'\"":
            quote = c
        elif c == "#" and (k == 0 or command[k - 1].isspace()):
            return command[:k]
    return command


_help_cache = {}


def mosyn_help(build, words):
    key = tuple(words)
    if key not in _help_cache:
        exe = os.path.join(build, "mosyn")
        try:
            r = subprocess.run([exe, *words, "--help"], capture_output=True, text=True, timeout=60)
            _help_cache[key] = (r.returncode, r.stdout + r.stderr)
        except (OSError, subprocess.TimeoutExpired) as e:
            _help_cache[key] = (1, str(e))
    return _help_cache[key]


def check_options(build, command):
    """Problems with the mosyn subcommands and options of a command line ([] when none)."""
    problems = []
    for part in re.split(r"&&|\|\||;|\||&(?!&)", strip_comment(command)):
        words = part.split()
        at = next((k for k, w in enumerate(words) if w == "mosyn" or w.endswith("/mosyn")), None)
        if at is None or at + 1 >= len(words) or words[at + 1].startswith("-"):
            continue
        sub = [words[at + 1]]
        if sub[0] == "data" and at + 2 < len(words):
            sub.append(words[at + 2])
        rc, text = mosyn_help(build, sub)
        usage = re.search(r"^Usage: \S+ (.*)$", text, re.M)
        if rc != 0 or not usage or not usage.group(1).startswith(" ".join(sub) + " "):
            problems.append(f"`mosyn {' '.join(sub)}` is not a command")
            continue
        known = set(re.findall(r"(?<![\w-])(--[a-z0-9][a-z0-9-]*)", text))
        for w in words[at + 1 + len(sub):]:
            flag = w.split("=", 1)[0]
            if re.fullmatch(r"--[a-z0-9][a-z0-9-]*", flag) and flag not in known:
                problems.append(f"`mosyn {' '.join(sub)}` has no option {flag}")
    return problems


def slug(heading):
    """GitHub's anchor of a Markdown heading."""
    text = re.sub(r"[`*_]|\[([^\]]*)\]\([^)]*\)", r"\1", heading.strip().lower())
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path):
    found, counts = set(), {}
    in_code = False
    with open(path, encoding="utf-8") as f:
        for line in f:
            if FENCE.match(line.rstrip("\n")):
                in_code = not in_code
            m = None if in_code else re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
            if m:
                s = slug(m.group(1))
                n = counts.get(s, 0)
                counts[s] = n + 1
                found.add(s if n == 0 else f"{s}-{n}")
    return found


LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")


def check_links(path):
    """Yields (line, problem) for relative links of a Markdown file that lead nowhere."""
    in_code = False
    with open(path, encoding="utf-8") as f:
        for no, line in enumerate(f, 1):
            if FENCE.match(line.rstrip("\n")):
                in_code = not in_code
                continue
            if in_code:
                continue
            for target in LINK.findall(re.sub(r"`[^`]*`", "", line)):
                if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I):
                    continue  # http:, https:, mailto:
                file_part, _, anchor = target.partition("#")
                dest = os.path.normpath(os.path.join(os.path.dirname(path), file_part)) if file_part else path
                if not os.path.exists(dest):
                    yield no, f"link to {target}: {os.path.relpath(dest, ROOT)} does not exist"
                elif anchor and dest.endswith(".md") and anchor not in anchors(dest):
                    yield no, f"link to {target}: no heading #{anchor} in {os.path.relpath(dest, ROOT)}"


def scratch_folder(build):
    """A temporary folder that looks like the repository root without copying it."""
    base = tempfile.mkdtemp(prefix="mosyn-docs-")
    repo = os.path.join(base, "repo")
    os.mkdir(repo)
    for name in os.listdir(ROOT):
        if name in (".git", "build"):
            continue
        os.symlink(os.path.join(ROOT, name), os.path.join(repo, name))
    os.symlink(build, os.path.join(repo, "build"))
    shared = os.path.normpath(os.path.join(ROOT, "..", "shared"))
    if os.path.isdir(shared):
        os.symlink(shared, os.path.join(base, "shared"))
    return base, repo


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("files", nargs="*")
    ap.add_argument("--build", default=os.environ.get("MOSYN_BUILD", os.path.join(ROOT, "build")))
    ap.add_argument("--timeout", type=float, default=float(os.environ.get("MOSYN_DOC_TIMEOUT", 120)))
    ap.add_argument("--links-only", action="store_true", help="check links (and options), run nothing")
    ap.add_argument("--list", action="store_true", help="print the commands that would run, run nothing")
    ap.add_argument("--times", action="store_true", help="print every command's wall time")
    args = ap.parse_args()
    build = os.path.abspath(args.build)
    files = [os.path.abspath(f) for f in args.files] or \
        [os.path.join(ROOT, "README.md")] + sorted(glob.glob(os.path.join(ROOT, "docs", "*.md")))
    have_data = os.path.isfile(os.path.join(ROOT, "..", "shared", "data", "bandai-namco-motion.tar.gz"))
    have_mosyn = os.access(os.path.join(build, "mosyn"), os.X_OK)
    if not have_mosyn and not args.list:
        print(f"check_doc_commands: {build}/mosyn not found: build it (make build) or pass --build DIR", file=sys.stderr)
        return 1
    # One OpenMP thread that sleeps when idle: on a loaded machine (ctest -j, other jobs) spinning
    # LibTorch threads otherwise wait for each other, several times slower.
    env = dict(os.environ, OMP_NUM_THREADS="1", OMP_WAIT_POLICY="passive")
    failures, ran, skipped = [], 0, 0
    started = time.time()
    for path in files:
        rel = os.path.relpath(path, ROOT)
        for no, problem in check_links(path):
            failures.append(f"{rel}:{no}: {problem}")
        todo = []
        for info, body in blocks(path):
            if not info or info[0] not in SHELLS:
                continue
            for no, command in commands(body):
                if have_mosyn:
                    for problem in check_options(build, command):
                        failures.append(f"{rel}:{no}: {problem}")
                if "no-run" in info:
                    continue
                if "needs-data" in info and not have_data:
                    skipped += 1
                    continue
                todo.append((no, command))
        if args.list:
            for no, command in todo:
                print(f"{rel}:{no}: {command}")
            continue
        if args.links_only or not todo:
            continue
        base, repo = scratch_folder(build)
        page_start = time.time()
        try:
            for no, command in todo:
                t0 = time.time()
                try:
                    r = subprocess.run(["bash", "-o", "pipefail", "-c", command], cwd=repo, env=env,
                                       capture_output=True, text=True, timeout=args.timeout)
                    rc, output = r.returncode, r.stdout + r.stderr
                except subprocess.TimeoutExpired as e:
                    rc = "timeout"
                    output = (e.stdout or b"").decode(errors="replace") + (e.stderr or b"").decode(errors="replace")
                ran += 1
                took = time.time() - t0
                if args.times:
                    print(f"  {took:6.1f} s  {rel}:{no}: {command[:100]}", flush=True)
                if rc != 0:
                    tail = "\n".join("    " + l for l in output.strip().split("\n")[-8:])
                    failures.append(f"{rel}:{no}: command failed ({'timed out after %g s' % args.timeout if rc == 'timeout' else 'exit %s' % rc}, {took:.1f} s): {command}\n{tail}")
        finally:
            shutil.rmtree(base, ignore_errors=True)
        print(f"{rel}: {len(todo)} commands in {time.time() - page_start:.1f} s", flush=True)
    if args.list:
        return 0
    for failure in failures:
        print(failure)
    print(f"check_doc_commands: {len(files)} pages, {ran} commands run, {skipped} skipped (no ../shared/data), "
          f"{len(failures)} problems, {time.time() - started:.0f} s")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
