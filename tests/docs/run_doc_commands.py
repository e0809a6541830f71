#!/usr/bin/env python3
"""Runs every shell block of the manual, as a reader would, and fails if one does not work.

Every ```sh, ```bash and ```console block of README.md, docs/**/*.md and the scenes' READMEs is
run with `bash -e` in a scratch copy of the repository (the files `git ls-files` lists, or the
source tree without build*/ and out/), whose build/ is a symbolic link to the real build
directory, so `build/renderer/lamina` works as written. Each document gets its own copy and runs
its blocks in order (a block sees the files the blocks above it wrote); each block is its own
bash process, started in the copy's root.

A comment on the line just above a block (one or more, consecutive) changes how it runs:
  <!-- docs-test: reduce --width 32 --height 24 --spp 2 -->   each flag's value in the block is
      replaced (`--spp 64` -> `--spp 2`); a flag the block does not contain is an error
  <!-- docs-test: env LAMINA_QUICK=1 -->                      exported before the block runs
  <!-- docs-test: replace BENCH_SPP=64 BENCH_SPP=2 -->          each OLD text replaced by NEW (pairs of
      words without spaces); an OLD the block does not contain is an error
  <!-- docs-test: not-run because it installs packages -->    not run; printed with its reason,
      and a marker without a reason is an error
Relative Markdown links ([text](path#anchor)) must name files that exist and, into a Markdown
file, a heading that exists.

Exit 0 when every block ran with exit status 0 and every link resolves; otherwise 1, with one
line per failure naming the document and the line of the block (`FILE:LINE: ...`).
Standard library only.
"""
import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

FENCE = re.compile(r'^(\s*)(`{3,})\s*([\w+-]*)\s*$')
MARKER = re.compile(r'^\s*<!--\s*docs-test:\s*(.*?)\s*-->\s*$')
SHELL_LANGUAGES = {'sh', 'bash', 'console'}
LINK = re.compile(r'(?<!!)\[[^\]]*\]\(([^)\s]+)\)|!\[[^\]]*\]\(([^)\s]+)\)')


class Block:
    def __init__(self, document, line, language, text, markers):
        self.document, self.line, self.language = document, line, language
        self.text, self.markers = text, markers

    def where(self):
        return f'{self.document}:{self.line}'


def parse_blocks(relative, lines):
    """The fenced blocks of one Markdown file, with the docs-test markers just above each."""
    blocks, i = [], 0
    while i < len(lines):
        match = FENCE.match(lines[i])
        if not match:
            i += 1
            continue
        indent, ticks, language = match.group(1), match.group(2), match.group(3).lower()
        markers, j = [], i - 1
        while j >= 0 and MARKER.match(lines[j]):
            markers.insert(0, MARKER.match(lines[j]).group(1))
            j -= 1
        body, k = [], i + 1
        while k < len(lines):
            end = re.match(r'^\s*(`{3,})\s*$', lines[k])
            if end and len(end.group(1)) >= len(ticks):
                break
            body.append(lines[k][len(indent):] if lines[k].startswith(indent) else lines[k].lstrip())
            k += 1
        blocks.append(Block(relative, i + 1, language, '\n'.join(body) + '\n', markers))
        i = k + 1
    return blocks


def console_commands(text):
    """A console block's commands: the `$ ` lines and their backslash continuations."""
    lines = text.splitlines()
    if not any(line.startswith('$ ') for line in lines):
        return text
    commands, continuing = [], False
    for line in lines:
        if line.startswith('$ ') or continuing:
            commands.append(line[2:] if line.startswith('$ ') and not continuing else line)
            continuing = line.rstrip().endswith('\\')
    return '\n'.join(commands) + '\n'


def reduce_flags(block, spec):
    """Replaces each `--flag VALUE` (or `--flag=VALUE`) of the block by the marker's value."""
    tokens = spec.split()
    if not tokens or len(tokens) % 2:
        raise ValueError(f'reduce needs flag and value pairs, got "{spec}"')
    text = block
    for flag, value in zip(tokens[0::2], tokens[1::2]):
        if not flag.startswith('-'):
            raise ValueError(f'reduce: "{flag}" is not a flag')
        pattern = re.compile(r'(?<![\w-])' + re.escape(flag) + r'(=|\s+)' + r"""('[^']*'|"[^"]*"|[^\s\\;|&)"'`]+)""")
        text, count = pattern.subn(lambda m: flag + m.group(1) + value, text)
        if count == 0:
            raise ValueError(f'reduce: the block has no {flag}')
    return text


def prepare(block):
    """(script to run, None) or (None, reason it is not run); raises ValueError on a bad marker."""
    script = console_commands(block.text) if block.language == 'console' else block.text
    prefix = []
    for marker in block.markers:
        word, _, rest = marker.partition(' ')
        rest = rest.strip()
        if word == 'not-run':
            reason = re.sub(r'^because\b', '', rest).strip()
            if not reason:
                raise ValueError('a not-run marker needs a reason: <!-- docs-test: not-run because ... -->')
            return None, reason
        if word == 'reduce':
            script = reduce_flags(script, rest)
        elif word == 'replace':
            tokens = rest.split()
            if not tokens or len(tokens) % 2:
                raise ValueError(f'replace needs OLD NEW pairs, got "{rest}"')
            for old, new in zip(tokens[0::2], tokens[1::2]):
                if old not in script:
                    raise ValueError(f'replace: the block has no {old}')
                script = script.replace(old, new)
        elif word == 'env':
            assignments = rest.split()
            if not assignments or not all(re.match(r'^[A-Za-z_]\w*=', a) for a in assignments):
                raise ValueError(f'env needs NAME=VALUE assignments, got "{rest}"')
            prefix.append('export ' + ' '.join(assignments))
        else:
            raise ValueError(f'unknown docs-test marker "{word}" (reduce, replace, env or not-run)')
    return '\n'.join(prefix + [script]), None


def slug(heading):
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r'`', '', heading.strip().lower())
    text = re.sub(r'[^\w\- ]', '', text)
    return text.replace(' ', '-')


def anchors(lines):
    found, in_fence = set(), False
    for line in lines:
        if FENCE.match(line) or re.match(r'^\s*`{3,}\s*$', line):
            in_fence = not in_fence
            continue
        if not in_fence and re.match(r'^#{1,6} ', line):
            base, n = slug(line.lstrip('#')), 0
            name = base
            while name in found:
                n += 1
                name = f'{base}-{n}'
            found.add(name)
    return found


def check_links(source, relative, lines):
    failures, in_fence = [], False
    for number, line in enumerate(lines, 1):
        if FENCE.match(line) or re.match(r'^\s*`{3,}\s*$', line):
            in_fence = not in_fence
            continue
        if in_fence:
            continue
        for match in LINK.finditer(re.sub(r'`[^`]*`', '', line)):
            target = match.group(1) or match.group(2)
            if re.match(r'^[a-z]+:', target):
                continue
            path, _, anchor = target.partition('#')
            here = os.path.dirname(os.path.join(source, relative))
            full = os.path.normpath(os.path.join(here, path)) if path else os.path.join(source, relative)
            if not os.path.exists(full):
                failures.append(f'{relative}:{number}: link to a missing file: {target}')
            elif anchor and full.endswith('.md'):
                with open(full, encoding='utf-8') as f:
                    if anchor not in anchors(f.read().splitlines()):
                        failures.append(f'{relative}:{number}: link to a missing heading: {target}')
    return failures


def documents(source):
    found = []
    for top in ('README.md',):
        if os.path.exists(os.path.join(source, top)):
            found.append(top)
    for folder in ('docs', 'scenes'):
        for root, dirs, files in os.walk(os.path.join(source, folder)):
            dirs.sort()
            for name in sorted(files):
                if name.endswith('.md') and (folder == 'docs' or name.startswith('README')):
                    found.append(os.path.relpath(os.path.join(root, name), source))
    return found


def source_files(source):
    try:
        listed = subprocess.run(['git', 'ls-files', '-z', '--cached', '--others', '--exclude-standard'],
                                cwd=source, capture_output=True, check=True).stdout
        return [f for f in listed.decode().split('\0') if f and os.path.isfile(os.path.join(source, f))]
    except (OSError, subprocess.CalledProcessError):
        files = []
        for root, dirs, names in os.walk(source):
            dirs[:] = [d for d in dirs if not (d.startswith('build') or d in ('out', '.git'))]
            files += [os.path.relpath(os.path.join(root, n), source) for n in names]
        return files


def scratch_copy(source, files, build, parent):
    root = tempfile.mkdtemp(prefix='copy-', dir=parent)
    for relative in files:
        target = os.path.join(root, relative)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copy2(os.path.join(source, relative), target)
    if os.path.lexists(os.path.join(root, 'build')):
        shutil.rmtree(os.path.join(root, 'build'))
    os.symlink(os.path.abspath(build), os.path.join(root, 'build'))
    return root


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--source', required=True, help='the repository (source tree)')
    parser.add_argument('--build', required=True, help='the build directory build/ should point at')
    parser.add_argument('--documents', nargs='*', help='Markdown files relative to --source '
                        '(default: README.md, docs/**/*.md, scenes/**/README*.md)')
    parser.add_argument('--keep', action='store_true', help='keep the scratch copies')
    args = parser.parse_args()
    source = os.path.abspath(args.source)
    names = args.documents or documents(source)
    files = source_files(source)
    scratch = tempfile.mkdtemp(prefix='lamina-docs-')
    failures, ran, not_run, started = [], 0, 0, time.monotonic()
    try:
        for relative in names:
            with open(os.path.join(source, relative), encoding='utf-8') as f:
                lines = f.read().splitlines()
            failures += check_links(source, relative, lines)
            blocks = [b for b in parse_blocks(relative, lines) if b.language in SHELL_LANGUAGES]
            if not blocks:
                continue
            copy = scratch_copy(source, files, args.build, scratch)
            for block in blocks:
                try:
                    script, reason = prepare(block)
                except ValueError as error:
                    failures.append(f'{block.where()}: {error}')
                    print(f'FAIL {block.where()}: {error}', flush=True)
                    continue
                if script is None:
                    not_run += 1
                    print(f'NOT RUN {block.where()} because {reason}:')
                    print(''.join('    ' + l + '\n' for l in block.text.splitlines()), end='', flush=True)
                    continue
                ran += 1
                t0 = time.monotonic()
                result = subprocess.run(['bash', '-e', '-o', 'pipefail', '-c', script], cwd=copy,
                                        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                        errors='replace')
                seconds = time.monotonic() - t0
                if result.returncode != 0:
                    failures.append(f'{block.where()}: exit status {result.returncode}')
                    print(f'FAIL {block.where()} ({seconds:.1f} s): exit status {result.returncode}; '
                          f'the block as run:')
                    print(''.join('    ' + l + '\n' for l in script.splitlines()), end='')
                    print('  its output (last 40 lines):')
                    print(''.join('    ' + l + '\n' for l in result.stdout.splitlines()[-40:]), end='',
                          flush=True)
                else:
                    print(f'ok {block.where()} ({seconds:.1f} s)', flush=True)
    finally:
        if args.keep:
            print(f'scratch copies kept in {scratch}')
        else:
            shutil.rmtree(scratch, ignore_errors=True)
    print(f'{ran} blocks run, {not_run} not run (reasons above), {len(failures)} failures, '
          f'{time.monotonic() - started:.0f} s')
    for failure in failures:
        print(f'docs_commands: {failure}')
    return 1 if failures else 0


if __name__ == '__main__':
    sys.exit(main())
