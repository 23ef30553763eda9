#!/usr/bin/env bash
# Makes assets/fonts/DejaVuSans-subset.ttf and DejaVuSans-Bold-subset.ttf, the fonts the pictures
# are drawn with (src/render/text.rs embeds them), from Debian's fonts-dejavu-core:
# DejaVu Sans cut down to Basic Latin, Latin-1 and the few symbols the pictures use (µ ² ³ ≤ ≥ ±
# · ° – — × ρ Φ γ θ Σ Ē ∆ ‰ ′ → ←), hinting dropped. fontTools' pyftsubset (PyPI) does the cut.
# Licence: Bitstream Vera Fonts licence with the DejaVu changes in the public domain
# (assets/fonts/LICENSE); a subset is a modification, allowed as long as the name carries neither
# "Bitstream" nor "Vera".
set -euo pipefail
cd "$(dirname "$0")/.."
SRC=/usr/share/fonts/truetype/dejavu
[ -f "$SRC/DejaVuSans.ttf" ] || apt-get install -y -q fonts-dejavu-core >/dev/null
python3 -c 'import fontTools' 2>/dev/null || python3 -m pip install -q "fonttools>=4.60"
UNICODES="U+0020-007E,U+00A0-00FF,U+0100-0113,U+0393,U+0394,U+03A3,U+03A6,U+03B3,U+03B8,U+03BC,U+03C1,U+2013,U+2014,U+2022,U+2032,U+2030,U+2190,U+2192,U+2206,U+2211,U+2212,U+2264,U+2265,U+22C5,U+2248"
for face in DejaVuSans DejaVuSans-Bold; do
  python3 -m fontTools.subset "$SRC/$face.ttf" --unicodes="$UNICODES" \
    --no-hinting --layout-features='kern,liga' --output-file="assets/fonts/$face-subset.ttf"
done
cp /usr/share/doc/fonts-dejavu-core/copyright assets/fonts/LICENSE
ls -l assets/fonts
