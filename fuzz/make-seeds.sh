#!/usr/bin/env bash
# Seeds the fuzz corpora from real files, generated here rather than committed:
#   corpus/tg_open     .tg files baked by `pocketsplat bake` from the Stanford bunny (res4) and the
#                      demo's trefoil knot, 512-byte blocks, small depths, ρ = 2 and 3, with colours
#   corpus/ply_import  small PLY files: ASCII, binary little and big endian, gzipped, with colours,
#                      the bunny (res4) itself
#   corpus/tg_render   empty: its input is structured (see fuzz_targets/tg_render.rs), and the empty
#                      input already means "the first baked file, unchanged"
#   corpus/pack_open   one byte per base pack (0, 1, 2: shadows off, one-pass, two-pass), which
#                      picks that pack unchanged; the fuzzer grows edits after it
#   corpus/tg_stream   empty: structured like tg_render (the empty input streams the first baked
#                      file through a medium that never fails)
#   corpus/cli_numbers sizes, counts, floats and --limits lists as the command line takes them
#   corpus/scene_toml  the scene files in boards/sim/scenes and a small one of each object kind
# Usage: fuzz/make-seeds.sh   (from anywhere; needs python3 and the models in ../shared/models or
# $POCKETSPLAT_MODELS)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$here")"
models="${POCKETSPLAT_MODELS:-$root/../shared/models}"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$root/target}"
cargo build -q --manifest-path "$root/Cargo.toml" -p pocketsplat-sim --no-default-features --bin pocketsplat
bin="$CARGO_TARGET_DIR/debug/pocketsplat"

mkdir -p "$here/corpus/tg_open" "$here/corpus/ply_import" "$here/corpus/tg_render" \
  "$here/corpus/pack_open" "$here/corpus/tg_stream"
for i in 0 1 2; do printf "\\x0$i" > "$here/corpus/pack_open/base-$i"; done
mkdir -p "$here/corpus/cli_numbers" "$here/corpus/scene_toml"
i=0
for n in 0 4096 64K 16m 1G 18446744073709551615 100000M 1.5 -40,60 30,20,2.5 nan 1e999 \
    "ply=4G,triangles=100M" "bake=1G" " 7 "; do
  printf '%s' "$n" > "$here/corpus/cli_numbers/n$i"; i=$((i + 1))
done
install -m 644 "$root"/boards/sim/scenes/*.toml "$here/corpus/scene_toml/"
printf '%s\n' '[materials.m]' 'color = [0.5, 0.5, 0.5]' 'ambient = 0.2' 'diffuse = 0.8' \
  'specular = 0.0' 'exponent = 1.0' '[[objects]]' 'name = "g"' 'material = "m"' \
  'ground = { size = 4.0, tiles = 4 }' 'depth = 3' '[[objects]]' 'name = "f"' 'material = "m"' \
  'file = "x.tg"' '[[views]]' 'name = "v"' 'az = 30.0' 'el = 20.0' 'dist = 2.5' \
  > "$here/corpus/scene_toml/small.toml"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

# Small meshes: the trefoil tube of demo.rs (coarse), an octahedron, a coloured tetrahedron.
python3 - "$tmp" <<'EOF'
import gzip, math, struct, sys
out = sys.argv[1]

def trefoil(segments=24, sides=5, tube=0.45):
    def curve(t):
        return [math.sin(t) + 2 * math.sin(2 * t), math.cos(t) - 2 * math.cos(2 * t), -math.sin(3 * t)]
    def sub(a, b): return [a[i] - b[i] for i in range(3)]
    def cross(a, b): return [a[1]*b[2]-a[2]*b[1], a[2]*b[0]-a[0]*b[2], a[0]*b[1]-a[1]*b[0]]
    def norm(a):
        l = math.sqrt(sum(x * x for x in a)); return [x / l for x in a]
    v, f = [], []
    for i in range(segments):
        t = 2 * math.pi * i / segments
        p, q = curve(t), curve(t + 1e-4)
        tan = norm(sub(q, p)); side = norm(cross(tan, [0.3, 0.5, 1.0])); up = cross(side, tan)
        for j in range(sides):
            a = 2 * math.pi * j / sides
            v.append([p[k] + tube * (math.cos(a) * side[k] + math.sin(a) * up[k]) for k in range(3)])
    for i in range(segments):
        i2 = (i + 1) % segments
        for j in range(sides):
            j2 = (j + 1) % sides
            f.append((i * sides + j, i2 * sides + j, i2 * sides + j2))
            f.append((i * sides + j, i2 * sides + j2, i * sides + j2))
    return v, f

def ascii_ply(v, f, colors=None):
    head = ["ply", "format ascii 1.0", f"element vertex {len(v)}",
            "property float x", "property float y", "property float z"]
    if colors:
        head += ["property uchar red", "property uchar green", "property uchar blue"]
    head += [f"element face {len(f)}", "property list uchar int vertex_indices", "end_header"]
    lines = []
    for i, p in enumerate(v):
        c = " ".join(map(str, colors[i])) if colors else ""
        lines.append(f"{p[0]:.6g} {p[1]:.6g} {p[2]:.6g} {c}".rstrip())
    lines += ["3 %d %d %d" % t for t in f]
    return ("\n".join(head + lines) + "\n").encode()

def binary_ply(v, f, big, colors=None):
    e = ">" if big else "<"
    head = ["ply", "format binary_%s_endian 1.0" % ("big" if big else "little"),
            f"element vertex {len(v)}", "property float x", "property float y", "property float z"]
    if colors:
        head += ["property uchar red", "property uchar green", "property uchar blue"]
    head += [f"element face {len(f)}", "property list uchar uint vertex_indices", "end_header"]
    body = b""
    for i, p in enumerate(v):
        body += struct.pack(e + "3f", *p)
        if colors:
            body += bytes(colors[i])
    for t in f:
        body += struct.pack(e + "B3I", 3, *t)
    return ("\n".join(head) + "\n").encode() + body

tv, tf = trefoil()
octa_v = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]
octa_f = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
tet_v = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
tet_f = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
tet_c = [[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]]
files = {
    "trefoil.ply": ascii_ply(tv, tf),
    "trefoil-le.ply": binary_ply(tv, tf, False),
    "octahedron.ply": ascii_ply(octa_v, octa_f),
    "tetra-colour.ply": ascii_ply(tet_v, tet_f, tet_c),
    "tetra-colour-be.ply": binary_ply(tet_v, tet_f, True, tet_c),
    "tetra-colour-le.ply": binary_ply(tet_v, tet_f, False, tet_c),
    "octahedron.ply.gz": gzip.compress(ascii_ply(octa_v, octa_f), mtime=0),
}
for name, data in files.items():
    open(f"{out}/{name}", "wb").write(data)
EOF

install -m 644 "$tmp"/*.ply "$tmp"/*.gz "$here/corpus/ply_import/"
install -m 644 "$models/bun_zipper_res4.ply" "$here/corpus/ply_import/bunny-res4.ply"

bake() { # mesh out rho depth
    "$bin" bake "$1" -o "$here/corpus/tg_open/$2" --rho "$3" --depth "$4" --block-size 512 2>/dev/null
}
bake "$models/bun_zipper_res4.ply" bunny-r3-d3 3 3
bake "$models/bun_zipper_res4.ply" bunny-r2-d4 2 4
bake "$tmp/trefoil.ply" trefoil-r3-d3 3 3
bake "$tmp/trefoil.ply" trefoil-r2-d3 2 3
bake "$tmp/tetra-colour.ply" tetra-colour-r3-d2 3 2
bake "$tmp/octahedron.ply" octahedron-r4-d2 4 2
du -sh "$here"/corpus/*
