#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The Python module hybrid_broadphase built on the GPU machine for that
machine's own python3, from what scripts/gpu-check --prepare carries
(docs/gpu.md). Standard library only: the GPU machine has no Debian package.

  gpu_python_module.py prepare MAIN_BUILD CARRY
      here, after the main build: CARRY/python/ gets the archives and shared
      libraries of the module's link line (read from ninja), the headers it
      includes from outside the repository and the C and C++ libraries
      (pybind11 and any other package's, found in its objects' dependencies),
      Debian's pure-Python pytest with what it imports (site/), and
      recipe.json: sources, definitions and link order.
  gpu_python_module.py build CARRY BUILD_DIR STATUS_JSON
      there: compiles the recipe's sources with the running interpreter's
      headers and the newest pybind11 among the carried one, the
      interpreter's `pybind11` package and the one inside torch; links the
      carried archives into BUILD_DIR/module/hybrid_broadphase<EXT_SUFFIX>.
      STATUS_JSON says whether it was built and, if not, why.
"""
import glob
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import sysconfig
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TARGET = "hybrid_broadphase_python"
# Libraries every Linux C++ toolchain has: linked by name, never carried.
SYSTEM_LIBRARY = re.compile(r"^lib(c|m|dl|pthread|rt|stdc\+\+|gcc_s)\.(a|so(\.\d+)*)$")
# /usr/include entries of the C library, the kernel, the compiler and Python:
# the GPU machine has its own.
SYSTEM_HEADER_PACKAGES = re.compile(r"^(libc6-dev|linux-libc-dev|libstdc\+\+-\d+-dev|libgcc-\d+-dev|libcrypt-dev|"
                                    r"libpython3[.\d]*-dev|python3[.\d]*-dev)(:\w+)?$")
# Debian's pytest and what it imports on Python >= 3.11 (pure Python).
PYTEST_PACKAGES = ["pytest", "_pytest", "pluggy", "iniconfig", "packaging", "attr", "attrs", "py", "py.py"]
DIST_PACKAGES = "/usr/lib/python3/dist-packages"


def ninja_lines(build, *args):
    return subprocess.run(["ninja", "-C", build, "-t", *args], check=True, capture_output=True,
                          text=True).stdout.splitlines()


def soname(path):
    try:
        out = subprocess.run(["objdump", "-p", path], check=True, capture_output=True, text=True).stdout
        m = re.search(r"^\s*SONAME\s+(\S+)", out, re.M)
        if m:
            return m.group(1)
    except (OSError, subprocess.CalledProcessError):
        pass
    return os.path.basename(path)


def header_owners(paths):
    """{path: {package, ...}} as dpkg tells (empty without dpkg)."""
    try:
        out = subprocess.run(["dpkg", "-S", *paths], capture_output=True, text=True).stdout
    except OSError:
        return {}
    owners = {}
    for line in out.splitlines():
        packages, _, path = line.partition(": ")
        owners.setdefault(path.strip(), set()).update(p.strip() for p in packages.split(","))
    return owners


def prepare(main_build, carry):
    main_build = os.path.abspath(main_build)
    dest = os.path.join(carry, "python")
    shutil.rmtree(dest, ignore_errors=True)
    os.makedirs(os.path.join(dest, "lib"))
    os.makedirs(os.path.join(dest, "include"))
    os.makedirs(os.path.join(dest, "site"))
    commands = ninja_lines(main_build, "commands", TARGET)
    compiles = [shlex.split(c) for c in commands if " -c " in c and "/python/src/" in c]
    if not compiles or " -shared " not in commands[-1]:
        sys.exit(f"gpu_python_module: no {TARGET} in {main_build} (configure the main build with Python on)")

    # Sources and definitions: the main build's own compile lines.
    sources, defines, objects = [], [], []
    for words in compiles:
        src = words[words.index("-c") + 1]
        sources.append(os.path.relpath(os.path.realpath(src), REPO))
        objects.append(words[words.index("-o") + 1])
        defines += [w for w in words if w.startswith("-D") and not w.endswith("_EXPORTS") and w not in defines]

    # Link order as the main build's, archives and shared libraries carried.
    link, carried = [], {}
    words = shlex.split(commands[-1])
    out = words[words.index("-o") + 1]
    for w in words:
        if w == out or w.endswith(".o") or not re.search(r"\.(a|so(\.\d+)*)$", w):
            if w.startswith("-l"):
                link.append(w)
            continue
        path = w if os.path.isabs(w) else os.path.join(main_build, w)
        base = os.path.basename(path)
        m = SYSTEM_LIBRARY.match(base)
        if m:
            link.append("-l" + m.group(1))
            continue
        if not os.path.exists(path):
            sys.exit(f"gpu_python_module: {path} not built (build {TARGET} first)")
        name = base if base.endswith(".a") else soname(path)
        if carried.setdefault(name, os.path.realpath(path)) != os.path.realpath(path):
            sys.exit(f"gpu_python_module: two libraries named {name}: {carried[name]}, {path}")
        if not os.path.exists(os.path.join(dest, "lib", name)):
            shutil.copy2(path, os.path.join(dest, "lib", name))
        link.append("lib/" + name)

    # Headers from outside the repository: each /usr/include header the
    # objects read that no system package (the C library's, the compiler's,
    # Python's) owns, with its whole top directory (pybind11/, tbb/...).
    read = sorted({os.path.normpath(line.strip()) for line in ninja_lines(main_build, "deps", *objects)
                   if line.strip().startswith("/usr/include/")})
    owners = header_owners(read)
    headers = []
    for path in read:
        packages = owners.get(path, set())
        system = not packages or all(SYSTEM_HEADER_PACKAGES.match(p) for p in packages)
        if system and path.split("/")[3] != "pybind11":
            continue
        relative = os.path.relpath(path, "/usr/include")
        top = relative.split("/")[0]
        if top in headers:
            continue
        if top.endswith("-linux-gnu"):  # a multiarch directory: the file alone
            top = relative
        src, target = "/usr/include/" + top, os.path.join(dest, "include", top)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        (shutil.copytree if os.path.isdir(src) else shutil.copy2)(src, target)
        headers.append(top)
    if "pybind11" not in headers:
        sys.exit(f"gpu_python_module: no /usr/include/pybind11 in the dependencies of {TARGET}'s objects "
                 f"(build {TARGET} first)")

    # pytest for an interpreter that has none (appended to sys.path there,
    # after the interpreter's own packages).
    site = os.path.join(dest, "site")
    for name in PYTEST_PACKAGES:
        matches = [os.path.join(DIST_PACKAGES, name)] + glob.glob(os.path.join(DIST_PACKAGES, name + "-*-info"))
        for m in [m for m in matches if os.path.exists(m)]:
            target = os.path.join(site, os.path.basename(m))
            if os.path.isdir(m):
                shutil.copytree(m, target, ignore=shutil.ignore_patterns("__pycache__"))
            else:
                shutil.copy2(m, target)
    if not os.path.isdir(os.path.join(site, "_pytest")):
        sys.exit(f"gpu_python_module: no pytest in {DIST_PACKAGES} (apt-get install python3-pytest)")

    with open(os.path.join(dest, "recipe.json"), "w") as f:
        json.dump({"sources": sources, "defines": defines, "link": link, "headers": headers,
                   "main_build_module": os.path.basename(out)}, f, indent=2)
    print(f"gpu_python_module: {len(sources)} sources, link {' '.join(link)}; headers {', '.join(headers)}; pytest")


def pybind11_version(include):
    try:
        text = open(os.path.join(include, "pybind11", "detail", "common.h")).read()
    except OSError:
        return None
    parts = [re.search(rf"#define PYBIND11_VERSION_{k} (\d+)", text) for k in ("MAJOR", "MINOR", "PATCH")]
    return tuple(int(p.group(1)) for p in parts) if all(parts) else None


def module_include(module, expression):
    """An include directory a package of this interpreter names, or None."""
    r = subprocess.run([sys.executable, "-c", f"import os, {module}; print({expression})"],
                       capture_output=True, text=True, timeout=60)
    return r.stdout.strip() if r.returncode == 0 and r.stdout.strip() else None


def build(carry, build_dir, status_path):
    start = time.time()
    status = {"built": False, "carried": True, "python": sys.version.split()[0], "executable": sys.executable}

    def finish(reason=None):
        status["seconds"] = round(time.time() - start, 1)
        if reason:
            status["reason"] = reason
            print("gpu_python_module: not built: " + reason)
        with open(status_path, "w") as f:
            json.dump(status, f, indent=2)
        return 0 if status["built"] else 1

    carried = os.path.join(os.path.abspath(carry), "python")
    try:
        recipe = json.load(open(os.path.join(carried, "recipe.json")))
    except OSError:
        status["carried"] = False
        return finish("nothing carried (scripts/gpu-check --prepare after the main build with Python on)")
    module_dir = os.path.join(build_dir, "module")
    shutil.rmtree(build_dir, ignore_errors=True)
    os.makedirs(module_dir)

    # The interpreter's headers.
    tried = [p for p in (sysconfig.get_paths().get("include"), sysconfig.get_config_var("INCLUDEPY")) if p]
    python_include = next((p for p in tried if os.path.exists(os.path.join(p, "Python.h"))), None)
    if not python_include:
        return finish(f"no Python.h for Python {status['python']} ({sys.executable}) in "
                      f"{', '.join(sorted(set(tried)))}: the interpreter's development headers are not installed")
    status["python_include"] = python_include

    # pybind11: the newest of the carried one (Debian's), the interpreter's
    # package and torch's copy (an older one may not know this Python).
    candidates = [("carried (Debian)", os.path.join(carried, "include"))]
    for label, module, expression in (("pybind11 package", "pybind11", "pybind11.get_include()"),
                                      ("torch", "torch", "os.path.join(os.path.dirname(torch.__file__), 'include')")):
        try:
            path = module_include(module, expression)
        except subprocess.TimeoutExpired:
            path = None
        if path:
            candidates.append((label, path))
    found = [(pybind11_version(p), label, p) for label, p in candidates if pybind11_version(p)]
    status["pybind11_candidates"] = [f"{label} {'.'.join(map(str, v))} ({p})" for v, label, p in found]
    if not found:
        return finish("no pybind11 headers (carried, pybind11 package or torch)")
    cxx = os.environ.get("CXX", "c++")
    launcher = [shutil.which("ccache")] if shutil.which("ccache") else []  # here; the GPU machine has none
    status["compiler"] = subprocess.run([cxx, "--version"], capture_output=True, text=True).stdout.split("\n")[0]
    flags = ["-std=c++20", "-O3", "-DNDEBUG", "-fPIC", "-fvisibility=hidden", "-Wall", "-Wextra", "-ffp-contract=off"]

    def compile_all(pybind11_dir, attempt):
        """[(source, object)] and the failures, compiled in parallel."""
        # Only pybind11 from that directory (torch's holds many other headers).
        staged = os.path.join(build_dir, f"pybind11-include-{attempt}")
        os.makedirs(staged)
        os.symlink(os.path.join(pybind11_dir, "pybind11"), os.path.join(staged, "pybind11"))
        includes = ["-I" + os.path.join(REPO, "include"), "-isystem", staged,
                    "-isystem", os.path.join(carried, "include"), "-isystem", python_include]
        jobs, failed = [], []
        for src in recipe["sources"]:
            obj = os.path.join(build_dir, os.path.basename(src) + ".o")
            cmd = [*launcher, cxx, *flags, *recipe["defines"], *includes, "-MD", "-MF", obj + ".d",
                   "-c", os.path.join(REPO, src), "-o", obj]
            print(" ".join(shlex.quote(c) for c in cmd), flush=True)
            jobs.append((src, obj, subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)))
        for src, obj, job in jobs:
            text = job.communicate()[0]
            sys.stdout.write(text)
            if job.returncode != 0:
                lines = text.splitlines()
                first = next((l for l in lines if "error" in l), lines[-1] if lines else "")
                failed.append(f"{src} (exit {job.returncode}): {first}")
        return [(src, obj) for src, obj, _ in jobs], failed

    # The newest first (an older one may not know this Python); should it
    # not compile, the next (the carried one among equals comes first).
    failures = []
    for attempt, (version, label, pybind11_dir) in enumerate(sorted(found, key=lambda f: f[0], reverse=True)[:2]):
        status["pybind11"] = {"version": ".".join(map(str, version)), "from": label, "dir": pybind11_dir}
        objects, failed = compile_all(pybind11_dir, attempt)
        if not failed:
            break
        failures.append(f"with pybind11 {status['pybind11']['version']} ({label}): " + "; ".join(failed))
    status["pybind11_failures"] = failures
    if failed:
        return finish("compile failed " + " / ".join(failures))

    # Which pybind11 the objects read: the chosen one only.
    read = set()
    for _, obj in objects:
        for path in re.findall(r"\S*/pybind11/[^\s\\]+", open(obj + ".d").read()):
            read.add(os.path.realpath(path).split("/pybind11/")[0])
    status["pybind11_read_from"] = sorted(read)

    lib = os.path.join(carried, "lib")
    suffix = sysconfig.get_config_var("EXT_SUFFIX") or ".so"
    module = os.path.join(module_dir, "hybrid_broadphase" + suffix)
    link = [w if w.startswith("-l") else os.path.join(carried, w) for w in recipe["link"]]
    cmd = [cxx, "-shared", "-fPIC", "-o", module, *[obj for _, obj in objects], *link, "-Wl,-rpath," + lib]
    print(" ".join(shlex.quote(c) for c in cmd), flush=True)
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    sys.stdout.write(r.stdout)
    if r.returncode != 0:
        first = next((l for l in r.stdout.splitlines() if "undefined" in l or "error" in l), r.stdout.strip()[-300:])
        return finish(f"link failed (exit {r.returncode}): {first}")
    status.update(built=True, module=module)
    print(f"gpu_python_module: built {module} for Python {status['python']} with pybind11 "
          f"{status['pybind11']['version']} ({status['pybind11']['from']}) in {time.time() - start:.1f} s")
    return finish()


def main():
    if len(sys.argv) == 4 and sys.argv[1] == "prepare":
        prepare(sys.argv[2], sys.argv[3])
        return 0
    if len(sys.argv) == 5 and sys.argv[1] == "build":
        return build(sys.argv[2], sys.argv[3], sys.argv[4])
    sys.exit(__doc__)


if __name__ == "__main__":
    raise SystemExit(main())
