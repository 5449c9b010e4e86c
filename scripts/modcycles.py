#!/usr/bin/env python3
"""Module cycles of the workspace's crates: a pair of top-level modules of one crate that each
`use crate::` the other. Prints `CYCLE` lines (none expected) and `checked`.

    python3 scripts/modcycles.py    # from the workspace root
"""
import re,os,sys,itertools
for crate in ['firmware/src','host-sim/src','mcu-bench/src','controller-core/src','sensor-drivers/src']:
    mods={}
    for root,_,files in os.walk(crate):
        for f in files:
            if not f.endswith('.rs'): continue
            p=os.path.join(root,f); rel=os.path.relpath(p,crate)[:-3]
            name=rel.split('/')[0] if rel.split('/')[0] not in ('lib','main','bin') else None
            if name is None: continue
            txt=open(p).read()
            uses=set(re.findall(r'crate::(\w+)',txt))
            mods.setdefault(name,set()).update(u for u in uses if u!=name)
    for a,b in itertools.combinations(mods,2):
        if b in mods[a] and a in mods[b]: print(crate,'CYCLE',a,b)
print('checked')
