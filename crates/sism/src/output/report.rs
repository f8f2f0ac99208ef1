//! `report.html`: one page to look at what a command wrote (`study`, `sensitivity`, `bench` /
//! `compare-all`). The page is self-contained: no network, no external script or style; its images
//! are the PNG files beside it (relative links), so the folder can be copied or served as it is.
//!
//! What the page offers: headings and paragraphs, tables that sort on a click of their header
//! (numerically where a column reads as numbers), figures, a gallery of images side by side, and a
//! *flipper* that shows one of two chosen images in one place and swaps them on a click or a key, so
//! that differences between two images stand out.
//!
//! The page checks itself once loaded, for tests in a real browser: `<body data-images="L/N">`
//! (images loaded of all) and `data-errors="E"` (script errors seen), `data-ready="1"` when done.
//! Opened as `report.html#selftest` it also clicks a table header and a flipper and records whether
//! the rows came out sorted (`data-sort="ok"`) and the other image showed (`data-flip="ok"`).

use std::fmt::Write as _;
use std::path::Path;

/// A report under construction; [`Report::write`] saves it.
#[derive(Clone, Debug, Default)]
pub struct Report {
    title: String,
    body: String,
    flippers: usize,
}

/// One image of a gallery or a flipper.
#[derive(Clone, Debug)]
pub struct Picture {
    /// Its caption (also the flipper's choice).
    pub caption: String,
    /// The PNG, relative to the report's folder (forward slashes).
    pub src: String,
    /// A second image shown under it (an error map), relative.
    pub below: Option<String>,
}

/// `text` escaped for HTML text and attribute values.
pub fn escape(text: &str) -> String {
    let mut s = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => s.push_str("&amp;"),
            '<' => s.push_str("&lt;"),
            '>' => s.push_str("&gt;"),
            '"' => s.push_str("&quot;"),
            '\'' => s.push_str("&#39;"),
            c => s.push(c),
        }
    }
    s
}

/// Inline markdown of a table cell or paragraph: escaped, with `**bold**` and `` `code` ``.
fn inline(text: &str) -> String {
    let mut out = String::new();
    let mut bold = false;
    let mut code = false;
    let mut rest = text;
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix("**") {
            out.push_str(if bold { "</strong>" } else { "<strong>" });
            bold = !bold;
            rest = r;
        } else if let Some(r) = rest.strip_prefix('`') {
            out.push_str(if code { "</code>" } else { "<code>" });
            code = !code;
            rest = r;
        } else {
            let c = rest.chars().next().expect("not empty");
            out.push_str(&escape(&c.to_string()));
            rest = &rest[c.len_utf8()..];
        }
    }
    if code {
        out.push_str("</code>");
    }
    if bold {
        out.push_str("</strong>");
    }
    out
}

/// The cells of a markdown table row (`| a | b |`).
fn cells(line: &str) -> Vec<String> {
    let t = line.trim();
    let t = t.strip_prefix('|').unwrap_or(t);
    let t = t.strip_suffix('|').unwrap_or(t);
    t.split('|').map(|c| c.trim().to_string()).collect()
}

/// A markdown separator row (`|---|:---:|`).
fn is_separator(line: &str) -> bool {
    let c = cells(line);
    !c.is_empty()
        && c.iter()
            .all(|x| !x.is_empty() && x.chars().all(|ch| matches!(ch, '-' | ':' | ' ')))
}

impl Report {
    /// An empty report titled `title`.
    pub fn new(title: &str) -> Report {
        Report {
            title: title.to_string(),
            ..Report::default()
        }
    }

    /// A heading of `level` (1–4).
    pub fn heading(&mut self, level: u8, text: &str) -> &mut Self {
        let l = level.clamp(1, 4);
        let _ = writeln!(self.body, "<h{l}>{}</h{l}>", inline(text));
        self
    }

    /// A paragraph (inline markdown).
    pub fn paragraph(&mut self, text: &str) -> &mut Self {
        let _ = writeln!(self.body, "<p>{}</p>", inline(text));
        self
    }

    /// A sortable table: `header` cells, then rows (inline markdown in each cell).
    pub fn table(&mut self, header: &[String], rows: &[Vec<String>]) -> &mut Self {
        self.body.push_str("<table class=\"sortable\"><thead><tr>");
        for h in header {
            let _ = write!(self.body, "<th title=\"sort\">{}</th>", inline(h));
        }
        self.body.push_str("</tr></thead><tbody>\n");
        for r in rows {
            self.body.push_str("<tr>");
            for c in r {
                let _ = write!(self.body, "<td>{}</td>", inline(c));
            }
            self.body.push_str("</tr>\n");
        }
        self.body.push_str("</tbody></table>\n");
        self
    }

    /// Markdown as the commands write it (`sensitivity.md`, `roofline.md`, `pareto.md`): `#`
    /// headings, tables (sortable here) and paragraphs; a leading `#` heading is shown one level
    /// down from `top` (1–4).
    pub fn markdown(&mut self, text: &str, top: u8) -> &mut Self {
        let lines: Vec<&str> = text.lines().collect();
        let mut i = 0;
        let mut para: Vec<&str> = Vec::new();
        let flush = |para: &mut Vec<&str>, r: &mut Report| {
            if !para.is_empty() {
                r.paragraph(&para.join(" "));
                para.clear();
            }
        };
        while i < lines.len() {
            let line = lines[i].trim_end();
            if line.trim().is_empty() {
                flush(&mut para, self);
                i += 1;
            } else if let Some(h) = line.strip_prefix('#') {
                flush(&mut para, self);
                let depth = 1 + h.chars().take_while(|&c| c == '#').count() as u8;
                self.heading(top.saturating_add(depth - 1), h.trim_start_matches('#').trim());
                i += 1;
            } else if line.trim_start().starts_with('|') && i + 1 < lines.len() && is_separator(lines[i + 1])
            {
                flush(&mut para, self);
                let header = cells(line);
                let mut rows = Vec::new();
                i += 2;
                while i < lines.len() && lines[i].trim_start().starts_with('|') {
                    rows.push(cells(lines[i]));
                    i += 1;
                }
                self.table(&header, &rows);
            } else {
                para.push(line.trim());
                i += 1;
            }
        }
        flush(&mut para, self);
        self
    }

    /// A figure: the image `src` (relative) with a caption.
    pub fn figure(&mut self, src: &str, caption: &str) -> &mut Self {
        let _ = writeln!(
            self.body,
            "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>",
            escape(src),
            escape(caption),
            inline(caption)
        );
        self
    }

    /// Images side by side, each with its caption and, if any, a second image under it.
    pub fn gallery(&mut self, pictures: &[Picture]) -> &mut Self {
        self.body.push_str("<div class=\"gallery\">\n");
        for p in pictures {
            let _ = write!(
                self.body,
                "<figure><img src=\"{}\" alt=\"{}\">",
                escape(&p.src),
                escape(&p.caption)
            );
            if let Some(b) = &p.below {
                let _ = write!(
                    self.body,
                    "<img src=\"{}\" alt=\"{} (error)\">",
                    escape(b),
                    escape(&p.caption)
                );
            }
            let _ = writeln!(
                self.body,
                "<figcaption>{}</figcaption></figure>",
                inline(&p.caption)
            );
        }
        self.body.push_str("</div>\n");
        self
    }

    /// A flipper over `pictures`: two choices (the first two pictures at the start) and one place
    /// that shows either; a click on the image, or the space bar, swaps them.
    pub fn flipper(&mut self, pictures: &[Picture]) -> &mut Self {
        if pictures.is_empty() {
            return self;
        }
        let id = self.flippers;
        self.flippers += 1;
        let options = |selected: usize| {
            pictures
                .iter()
                .enumerate()
                .map(|(k, p)| {
                    format!(
                        "<option value=\"{k}\"{}>{}</option>",
                        if k == selected { " selected" } else { "" },
                        escape(&p.caption)
                    )
                })
                .collect::<String>()
        };
        let second = 1.min(pictures.len() - 1);
        let _ = write!(
            self.body,
            "<div class=\"flipper\" id=\"flip{id}\"><div class=\"choices\">A <select class=\"a\">{}</select> \
             B <select class=\"b\">{}</select> <button type=\"button\">flip (space)</button> \
             <span class=\"showing\"></span></div><div class=\"stack\">",
            options(0),
            options(second)
        );
        for (k, p) in pictures.iter().enumerate() {
            let _ = write!(
                self.body,
                "<img src=\"{}\" alt=\"{}\" data-k=\"{k}\"{}>",
                escape(&p.src),
                escape(&p.caption),
                if k == 0 { "" } else { " hidden" }
            );
        }
        self.body.push_str("</div></div>\n");
        self
    }

    /// The page's HTML.
    pub fn html(&self) -> String {
        format!(
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
             <meta name=\"viewport\" content=\"width=device-width\">\n<title>{}</title>\n<style>{STYLE}</style>\n\
             </head>\n<body data-ready=\"0\">\n<h1>{}</h1>\n{}<script>{SCRIPT}</script>\n</body></html>\n",
            escape(&self.title),
            escape(&self.title),
            self.body
        )
    }

    /// Writes the page to `path` (whole or not at all).
    pub fn write(&self, path: &Path) -> crate::Result<()> {
        crate::output::write_atomic(path, self.html().as_bytes())
    }
}

const STYLE: &str = "body{font-family:system-ui,sans-serif;margin:1.5em auto;max-width:1400px;padding:0 1em;color:#222}\
table{border-collapse:collapse;margin:1em 0;font-size:0.9em}\
th,td{border:1px solid #ccc;padding:0.25em 0.6em;text-align:right}\
th{background:#f2f2f2;cursor:pointer;user-select:none}th.asc::after{content:' ▲'}th.desc::after{content:' ▼'}\
td:first-child,th:first-child{text-align:left}tbody tr:nth-child(even){background:#fafafa}\
figure{display:inline-block;margin:0.5em;vertical-align:top}figure img{max-width:100%;display:block;margin-bottom:2px}\
figcaption{font-size:0.85em;text-align:center;max-width:340px}\
.gallery figure img{width:320px;image-rendering:pixelated}\
.flipper{margin:1em 0}.flipper .stack img{max-width:100%;image-rendering:pixelated;cursor:pointer}\
.flipper .showing{font-weight:bold;margin-left:1em}";

/// Sorting, flipping and the self-check (see the module's documentation).
const SCRIPT: &str = r#"
(function(){
  var errors = 0;
  window.addEventListener('error', function(){ errors++; document.body.dataset.errors = String(errors); });
  function key(text){
    var t = text.replace(/[%×,]/g,'').replace(/^\s*[+]/,'').trim();
    var n = parseFloat(t);
    return (t !== '' && !isNaN(n) && /^[-+]?[0-9.]/.test(t)) ? n : null;
  }
  document.querySelectorAll('table.sortable').forEach(function(table){
    table.querySelectorAll('th').forEach(function(th, col){
      th.addEventListener('click', function(){
        var body = table.tBodies[0];
        var rows = Array.prototype.slice.call(body.rows);
        var up = !th.classList.contains('asc');
        table.querySelectorAll('th').forEach(function(h){ h.classList.remove('asc','desc'); });
        th.classList.add(up ? 'asc' : 'desc');
        rows.sort(function(a, b){
          var x = a.cells[col] ? a.cells[col].textContent : '', y = b.cells[col] ? b.cells[col].textContent : '';
          var kx = key(x), ky = key(y), c;
          if (kx !== null && ky !== null) c = kx - ky;
          else if (kx !== null) c = -1; else if (ky !== null) c = 1;
          else c = x.localeCompare(y);
          return up ? c : -c;
        });
        rows.forEach(function(r){ body.appendChild(r); });
      });
    });
  });
  var flippers = [];
  document.querySelectorAll('.flipper').forEach(function(f){
    var a = f.querySelector('select.a'), b = f.querySelector('select.b');
    var imgs = f.querySelectorAll('.stack img'), label = f.querySelector('.showing');
    var onA = true;
    function show(){
      var k = onA ? a.value : b.value;
      imgs.forEach(function(img){ img.hidden = img.dataset.k !== k; });
      label.textContent = (onA ? 'A: ' : 'B: ') + (onA ? a : b).selectedOptions[0].textContent;
    }
    function flip(){ onA = !onA; show(); }
    a.addEventListener('change', function(){ onA = true; show(); });
    b.addEventListener('change', function(){ onA = false; show(); });
    f.querySelector('button').addEventListener('click', flip);
    imgs.forEach(function(img){ img.addEventListener('click', flip); });
    flippers.push(flip);
    show();
  });
  document.addEventListener('keydown', function(e){
    if (e.key === ' ' && flippers.length && e.target === document.body) { e.preventDefault(); flippers.forEach(function(f){ f(); }); }
  });
  window.addEventListener('load', function(){
    var imgs = Array.prototype.slice.call(document.images);
    var loaded = imgs.filter(function(i){ return i.complete && i.naturalWidth > 0; }).length;
    document.body.dataset.images = loaded + '/' + imgs.length;
    if (location.hash === '#selftest') selftest();
    document.body.dataset.errors = String(errors);
    document.body.dataset.ready = '1';
  });
  // Exercises the page as a user would (a click on each table's second header, then on the first
  // flipper's button) and records whether it did what it should: data-sort, data-flip.
  function selftest(){
    var sorted = 'none';
    document.querySelectorAll('table.sortable').forEach(function(table){
      var th = table.querySelectorAll('th')[1];
      if (!th || sorted === 'bad') return;
      th.click();
      var keys = Array.prototype.map.call(table.tBodies[0].rows, function(r){ return r.cells[1] ? r.cells[1].textContent : ''; });
      var ok = true;
      for (var i = 1; i < keys.length; i++) {
        var a = key(keys[i-1]), b = key(keys[i]);
        if (a !== null && b !== null ? a > b : (a === null && b !== null)) ok = false;
        if (a === null && b === null && keys[i-1].localeCompare(keys[i]) > 0) ok = false;
      }
      sorted = ok ? 'ok' : 'bad';
    });
    document.body.dataset.sort = sorted;
    var f = document.querySelector('.flipper');
    if (f) {
      f.querySelector('button').click();
      var shown = Array.prototype.filter.call(f.querySelectorAll('.stack img'), function(i){ return !i.hidden; });
      document.body.dataset.flip = (shown.length === 1 && shown[0].dataset.k === f.querySelector('select.b').value) ? 'ok' : 'bad';
    } else {
      document.body.dataset.flip = 'none';
    }
  }
})();
"#;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_tables_become_sortable_tables_and_text_is_escaped() {
        let mut r = Report::new("a <b> & c");
        r.markdown(
            "# Title\n\nsome **bold** and `code` <x>\n\n| name | ms |\n|---|---:|\n| a | 1.5 |\n| **b** | 10 |\n\nlast line\n",
            2,
        );
        let html = r.html();
        assert!(html.contains("<title>a &lt;b&gt; &amp; c</title>"), "{html}");
        assert!(html.contains("<h2>Title</h2>"), "{html}");
        assert!(html.contains("<strong>bold</strong>") && html.contains("<code>code</code> &lt;x&gt;"));
        assert!(html.contains("<table class=\"sortable\">"));
        assert!(html.contains("<td><strong>b</strong></td><td>10</td>"), "{html}");
        assert!(html.contains("<p>last line</p>"));
        assert!(!html.contains("<x>"));
    }

    #[test]
    fn a_flipper_offers_every_picture_and_shows_the_first() {
        let pic = |c: &str, s: &str| Picture {
            caption: c.into(),
            src: s.into(),
            below: None,
        };
        let mut r = Report::new("t");
        r.flipper(&[pic("one", "a.png"), pic("two \"q\"", "b.png")]);
        let html = r.html();
        assert!(
            html.contains("<img src=\"a.png\" alt=\"one\" data-k=\"0\">"),
            "{html}"
        );
        assert!(html.contains("<img src=\"b.png\" alt=\"two &quot;q&quot;\" data-k=\"1\" hidden>"));
        assert_eq!(html.matches("<option").count(), 4);
    }
}
