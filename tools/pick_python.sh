#!/bin/sh
# Prints the path of a Python that `make setup` can build .venv with: the one given as $1
# (the Makefile's PYTHON, default python3) when it is 3.10, 3.11 or 3.12, else the first of
# python3.12, python3.11, python3.10 on PATH. The pose model (mediapipe==0.10.14) has wheels
# for CPython 3.9-3.12 only (docs/decisions/pose-model.md). With none of them it prints one
# line on stderr that says what to install and exits 1, before anything is installed.
# POSIX sh and nothing else: it must run where no supported Python is.

preferred=${1:-python3}
found=""
looked=""
preferred_is="not found"

# The "major.minor" of the Python called $1; nothing when $1 is not found or fails to run.
python_version() {
    command -v "$1" >/dev/null 2>&1 || return 0
    "$1" -c 'import sys; print("%d.%d" % sys.version_info[:2])' 2>/dev/null
}

for candidate in "$preferred" python3.12 python3.11 python3.10; do
    if [ "$candidate" = "$preferred" ] && [ -n "$looked" ]; then
        continue
    fi
    looked=yes
    version=$(python_version "$candidate")
    case $version in
        3.10 | 3.11 | 3.12)
            if [ "$candidate" != "$preferred" ]; then
                echo "pick_python: $preferred is $preferred_is, not 3.10-3.12;" \
                    "using $candidate (Python $version)" >&2
            fi
            command -v "$candidate"
            exit 0
            ;;
        "") ;;
        *)
            [ "$candidate" = "$preferred" ] && preferred_is="Python $version"
            found="$found${found:+, }$candidate is $version"
            ;;
    esac
done

echo "imimic_gym needs Python 3.10, 3.11 or 3.12 (mediapipe==0.10.14, the pose model, has" \
    "no wheels for newer; found: ${found:-none}): get one (uv python install 3.12, pyenv," \
    "deadsnakes, or apt install python3.12-venv) and run make again, or" \
    "make PYTHON=/path/to/python3.12" >&2
exit 1
