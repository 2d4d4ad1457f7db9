"""Regenerate config/default.toml: the built-in defaults, each key commented from its Rust doc.

Usage (from the repository root):
    cargo test --lib print_default_config -- --ignored --nocapture 2>/dev/null \
        | sed -n '/^\[synth\]/,$p' | sed '/^test /,$d' | grep -v '^\.*$' > /tmp/defaults.toml
    python3 config/gen_default_toml.py /tmp/defaults.toml > config/default.toml
"""
import re, sys, tomllib
files = ['pipeline/config.rs', 'pipeline/core/segment/config.rs', 'pipeline/core/synth/round.rs',
         'pipeline/core/synth/schedule.rs', 'pipeline/core/synth/quirks.rs',
         'pipeline/core/fit/spring_rate.rs', 'pipeline/core/fit/thermal.rs', 'pipeline/core/fit/relaxation.rs']
structs = {}
for f in files:
    src = open(f).read()
    for m in re.finditer(r'((?:\s*///[^\n]*\n)*)\s*(?:#\[[^\n]*\]\s*)*pub struct (\w+)\s*\{(.*?)\n\}', src, re.S):
        doc, name, body = m.group(1), m.group(2), m.group(3)
        fields = {}
        for fm in re.finditer(r'((?:\s*///[^\n]*\n)+)(?:\s*#\[[^\n]*\]\n)*\s*pub (\w+): ([^,\n]+),', body):
            d = ' '.join(l.strip()[3:].strip() for l in fm.group(1).strip().split('\n'))
            fields[fm.group(2)] = (d, fm.group(3).strip())
        entry = (' '.join(l.strip()[3:].strip() for l in doc.strip().split('\n') if l.strip()), fields)
        # Two stages may name their knobs alike (segment::X, fit::X):
        # tables under [fit] take the fitting stages' definitions.
        key = ('fit:' if '/core/fit/' in f else '') + name
        structs.setdefault(key, entry)
vals = tomllib.loads(open(sys.argv[1]).read())
root = {'synth': 'SynthConfig', 'segment': 'SegmentConfig', 'fit': 'FitSettings'}
out = []
def fmt(v):
    if isinstance(v, bool): return 'true' if v else 'false'
    if isinstance(v, str): return '"%s"' % v
    if isinstance(v, float): return repr(v)
    if isinstance(v, list): return '[' + ', '.join(fmt(x) for x in v) + ']'
    return str(v)
def emit(path, table, sname, field_doc=''):
    key = 'fit:' + sname if path.startswith('fit.') and 'fit:' + sname in structs else sname
    doc, fields = structs.get(key, ('', {}))
    if field_doc.startswith('`['):
        doc = field_doc
    scalars = {k: v for k, v in table.items() if not isinstance(v, dict)}
    out.append('')
    if doc: out.append('# ' + doc)
    out.append('[%s]' % path)
    width = max([len(k) + 3 + len(fmt(v)) for k, v in scalars.items()] + [0])
    for k, v in scalars.items():
        line = '%s = %s' % (k, fmt(v))
        d = fields.get(k, ('', ''))[0]
        out.append(line.ljust(width) + ('  # ' + d if d else ''))
    for k, v in table.items():
        if isinstance(v, dict):
            fdoc, typ = fields.get(k, ('', 'X'))
            emit(path + '.' + k, v, typ, fdoc)
header = '''# tirebase configuration reference: every key with its default value and unit.
#
# These ARE the built-in defaults (a test keeps this file equal to them). To change something,
# write a TOML file with just the keys you want (any subset of any table) and pass it with
# --config FILE; command-line flags override both. Unknown keys are an error that names the key.
# Angles in deg (slip angle in ISO-W sign), loads in N (positive = compression), pressures in
# kPa, speeds in km/h, temperatures in degC, times in s, slips dimensionless.
#
# Generated from the code's doc comments by config/gen_default_toml.py (usage inside).'''
for k, sname in root.items():
    emit(k, vals[k], sname)
print(header + '\n'.join(out))
