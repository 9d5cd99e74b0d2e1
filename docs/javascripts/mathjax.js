// The site's one MathJax 3 configuration, loaded before the bundled tex-mml-chtml.js.
// Markdown pages: pymdownx.arithmatex (generic mode) wraps maths as \( \) and \[ \] in
// .arithmatex elements. Notebook pages (mkdocs-jupyter): markdown cells keep Jupyter's $ and $$
// inside .jp-RenderedMarkdown, LaTeX outputs sit in .jp-RenderedLatex. The page's content
// (.md-typeset) is skipped except inside those classes, so a dollar sign in code, output or
// prose elsewhere is never taken for maths.
// (An ignore pattern of ".*|" would also skip every child of a processed element: the <p> and
// <li> of a notebook's markdown cell.)
window.MathJax = {
  tex: {
    inlineMath: [["\\(", "\\)"], ["$", "$"]],
    displayMath: [["\\[", "\\]"], ["$$", "$$"]],
    processEscapes: true,
    processEnvironments: true,
  },
  options: {
    ignoreHtmlClass: "md-typeset|tex2jax_ignore|mathjax_ignore",
    processHtmlClass: "arithmatex|jp-RenderedMarkdown|jp-RenderedLatex",
  },
};

if (typeof document$ !== "undefined") {
  document$.subscribe(() => {
    if (!window.MathJax.startup || !window.MathJax.typesetPromise) {
      return; // the first page: MathJax typesets it on load
    }
    MathJax.startup.output.clearCache();
    MathJax.typesetClear();
    MathJax.texReset();
    MathJax.typesetPromise();
  });
}
