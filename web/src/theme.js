// The page's theme (issue 41): light, dark, or red light for a darkened
// room (dim red on black keeps the eyes adapted); chosen in the header and
// kept in this browser (localStorage). The live picture and the maps keep
// their own colours.
const KEY = 'chromo.theme';
const THEMES = ['light', 'dark', 'red'];

function apply(theme) {
  for (const name of THEMES) document.documentElement.classList.toggle(`theme-${name}`, name === theme);
}

// select: the header's <select id="theme">.
export function startTheme(select) {
  let theme = localStorage.getItem(KEY);
  if (!THEMES.includes(theme)) theme = window.matchMedia?.('(prefers-color-scheme: dark)').matches ? 'dark' : 'light';
  select.value = theme;
  apply(theme);
  select.addEventListener('change', () => {
    localStorage.setItem(KEY, select.value);
    apply(select.value);
  });
}
