"""The page's state in its address: ``/?robot=rp_2004_03_25&tab=model`` (robot, tab, exercise and
step, throw, and each parameter changed from the robot file's value as ``p.<name>=<value>``), so
that a reload restores the page and a link can be shared with a class.

viser's page does not tell the server its address, and the server cannot run scripts in it
except through HTML: ``bridge_html`` is an image that fails to load on purpose, whose ``onerror``
handler reports ``location.search`` (and later the panel tab selected by a click or a key) to the
server through a hidden text field, and ``write_html`` rewrites the address bar
(``history.replaceState``) and selects a tab. Only fixed text and values checked here go into those handlers.

Exercise ids are written as their file names (``2004-03-25#1`` as ``2004-03-25_1``): viser
rewrites the address unescaped when it connects, and a ``#`` would start the fragment.

>>> parse_query("?robot=rp_2004_03_25&tab=model&exercise=2004-03-25_1&step=3&junk=1&p.m1=2.5")
{'robot': 'rp_2004_03_25', 'tab': 'model', 'exercise': '2004-03-25#1', 'step': '3', 'p.m1': '2.5'}
>>> query_string({"robot": "rp_2004_03_25", "tab": "steps", "exercise": "2004-03-25#1", "throw": None})
'?robot=rp_2004_03_25&tab=steps&exercise=2004-03-25_1'
>>> query_string({"p.m1": address_number(2e20), "robot": "planar_2r"})
'?robot=planar_2r&p.m1=2e20'
"""
from __future__ import annotations

import html
import json
import re
import threading
import time
from typing import Dict, List, Mapping, Optional, Tuple
from urllib.parse import parse_qsl, urlencode

KEYS = ("robot", "tab", "exercise", "step", "throw")
PARAMETER_PREFIX = "p."                 # p.m1=2.5: the parameter m1 at 2.5 (a changed value)
PARAMETER_KEY = re.compile(r"^p\.[A-Za-z_][A-Za-z0-9_]{0,40}$")
BRIDGE_LABEL = "r2-page-report"        # the hidden text field the page reports through
#: a value the address may carry: names, exercise ids like 2013-07-15#1, step numbers
SAFE_VALUE = re.compile(r"^[A-Za-z0-9_.#\-]{1,80}$")

def parse_query(search: str) -> Dict[str, str]:
    """The known keys of an address's query (``?a=b&c=d``); the first value of each wins."""
    out: Dict[str, str] = {}
    for key, value in parse_qsl((search or "").lstrip("?"), keep_blank_values=False):
        if (key in KEYS or parameter_name(key)) and key not in out:
            out[key] = re.sub(r"_(\d+)$", r"#\1", value) if key == "exercise" else value
    return out


class PageRequests:
    """The addresses of the page loads the server answered lately, so that a new tab's first robot
    need not wait for the page's own report (0.3 s after it connects; the websocket's address
    carries no query). A tab takes the oldest recent load when every recent load had the same
    address; otherwise (two tabs opening different links at once) it waits for its report as
    before. A guess can be wrong (an old tab reconnecting while a new one loads): the page's report
    then corrects it (``Session``).

    >>> pages = PageRequests()
    >>> pages.note("/?robot=planar_2r&tab=model", {}); pages.take()
    '?robot=planar_2r&tab=model'
    >>> pages.take() is None        # taken: the next tab waits for its report
    True
    """

    def __init__(self, window: float = 5.0):
        self.window = window               # s: a page connects well within this after its load
        self._loads: List[Tuple[float, str]] = []
        self._lock = threading.Lock()

    def note(self, path: str, headers) -> None:
        """A request the server let in (``path`` without the token): a page load is remembered."""
        if str(headers.get("Upgrade", "")).lower() == "websocket":
            return
        where, _, query = path.partition("?")
        if where not in ("", "/"):
            return
        with self._lock:
            self._forget_old()
            self._loads.append((time.monotonic(), "?" + query if query else ""))

    def take(self) -> Optional[str]:
        """The address (``?robot=...`` or "") of a recent page load, when unambiguous."""
        with self._lock:
            self._forget_old()
            if not self._loads or len({query for _, query in self._loads}) > 1:
                return None
            return self._loads.pop(0)[1]

    def _forget_old(self) -> None:
        now = time.monotonic()
        self._loads = [(t, q) for t, q in self._loads if now - t < self.window]


def parameter_key(name: str) -> str:
    """The address key of parameter ``name``: ``p.m1``."""
    return PARAMETER_PREFIX + name


def parameter_name(key: str) -> Optional[str]:
    """The parameter an address key names (``p.m1`` -> ``m1``), or None for any other key."""
    return key[len(PARAMETER_PREFIX):] if PARAMETER_KEY.match(key) else None


def address_number(value: float) -> str:
    """A number as the address writes it: exact (the shortest text that reads back as the same
    float) and without the ``+`` an address would turn into a space.

    >>> address_number(12.0), address_number(0.1), address_number(-2.5e-07), address_number(1e16)
    ('12', '0.1', '-2.5e-07', '1e16')
    """
    text = repr(float(value)).replace("e+", "e")
    return text[:-2] if text.endswith(".0") else text


def query_string(state: Mapping[str, Optional[str]]) -> str:
    """``?key=value&...`` of the keys set in ``state``, in the order of KEYS, then the parameters."""
    keys = list(KEYS) + [k for k in state if parameter_name(k)]
    items = [(k, str(state[k]).replace("#", "_")) for k in keys if state.get(k) not in (None, "")]
    return "?" + urlencode(items) if items else "?"


def _handler(js: str) -> str:
    """An element whose ``onerror`` runs ``js`` once when inserted into the page."""
    return f'<img alt="" src="data:," style="display:none" onerror="{html.escape(js, quote=True)}">'


def bridge_html() -> str:
    """Reports ``location.search`` now, and the title of every panel tab clicked later, as
    ``url <search>`` and ``tab <title>`` through the hidden field. Drawn again (a new session after
    the server restarted, or the widget redrawn), it reports again: one queue for the page."""
    label = json.dumps(BRIDGE_LABEL)
    js = ("(function(){"
          "function field(){const l=[...document.querySelectorAll('label')].find(e=>e.textContent.trim()===" + label + ");"
          "if(!l)return null;const row=l.closest('.mantine-Flex-root');if(!row)return null;row.style.display='none';"
          "return row.querySelector('input');}"
          # one report at a time, 80 ms apart: the page sends a field's changes at most every 50 ms,
          # the last one only, so two reports written at once (the address and "drawn") lost one
          "const Q=window.__r2queue=window.__r2queue||{jobs:[],busy:false};"
          "function pump(){if(Q.busy||!Q.jobs.length)return;Q.busy=true;const [text,n]=Q.jobs.shift();"
          "(function attempt(k){const i=field();"
          "if(!i){if(k>0)setTimeout(()=>attempt(k-1),100);else{Q.busy=false;pump();}return;}"
          "Object.getOwnPropertyDescriptor(HTMLInputElement.prototype,'value').set.call(i,text);"
          "i.dispatchEvent(new Event('input',{bubbles:true}));setTimeout(()=>{Q.busy=false;pump();},80);})(n);}"
          "function report(text,n){Q.jobs.push([text,n]);pump();}"
          "window.__r2report=report;"
          "function selected(){const l=document.querySelector('[role=tablist]');"
          "const t=l&&l.querySelector('[role=tab][aria-selected=true]');if(t)report('tab '+t.textContent.trim(),20);}"
          "if(!window.__r2tabs){window.__r2tabs=true;for(const kind of ['click','keyup'])"
          "document.addEventListener(kind,function(e){if(e.target.closest&&e.target.closest('[role=tab]'))"
          "setTimeout(selected,100);},true);}"
          "report('url '+location.search,50);})()")
    return _handler(js)


def drawn_probe_html(serial: int = 0) -> str:
    """Reports ``drawn`` through the hidden field after the next animation frame: sent
    right after a robot's drawing, it tells the server that the page has drawn it. ``serial``
    makes every call's HTML new (so it runs again)."""
    return f'<span data-r2-drawn="{serial}"></span>' + _handler("requestAnimationFrame(()=>setTimeout(()=>"
                    "window.__r2report&&window.__r2report('drawn',20)))")


def write_html(state: Mapping[str, Optional[str]], select_tab: Optional[str] = None, serial: int = 0) -> str:
    """Rewrites the address bar to ``state``; with ``select_tab`` also selects that panel tab (by
    title, as the keyboard does: Enter on the tab) once it is in the page. ``serial`` makes every call's HTML new (so it runs again)."""
    js = f"history.replaceState(history.state,'',{json.dumps(query_string(state))});"
    if select_tab:
        js += ("(function f(n){const l=document.querySelector('[role=tablist]');"
               "const t=l&&[...l.querySelectorAll('[role=tab]')].find(e=>e.textContent.trim()===" + json.dumps(select_tab) + ");"
               "if(t){if(t.getAttribute('aria-selected')!=='true')"
               "t.dispatchEvent(new KeyboardEvent('keydown',{key:'Enter',bubbles:true}));}"
               "else if(n>0)setTimeout(()=>f(n-1),100);})(60);")
    return f'<span data-r2-url="{serial}"></span>' + _handler(js)


def safe(value: Optional[str]) -> bool:
    """Whether a value from the address may be used at all (checked again by its owner)."""
    return value is not None and bool(SAFE_VALUE.match(value))
