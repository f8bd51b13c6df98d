// Small shared helpers: DOM lookup, the status banner, colour conversion and lux formatting.
// A leaf module: it imports nothing, so any module may import it.

export const $ = (s) => document.querySelector(s);

/** Shows `text` in the banner (hides it when empty), optionally with a progress bar. */
export function showBanner(text, kind = "info", progress = null) {
  const b = $("#banner");
  b.hidden = !text;
  b.className = kind === "error" ? "error" : "";
  $("#banner-text").textContent = text || "";
  const p = $("#banner-progress");
  p.hidden = progress === null;
  if (progress !== null) p.value = progress;
}

export function srgbToLinear(hex) {
  const v = [1, 3, 5].map((i) => parseInt(hex.slice(i, i + 2), 16) / 255);
  return v.map((c) => (c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4)));
}

export function linearToSrgbHex(rgb) {
  const m = Math.max(...rgb, 1e-9);
  // Colours brighter than 1 are shown normalised; intensity carries the level.
  return "#" + rgb.map((c) => {
    const x = Math.min(1, Math.max(0, c / Math.max(1, m)));
    const s = x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055;
    return Math.round(s * 255).toString(16).padStart(2, "0");
  }).join("");
}

export const luminance = (c) => 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];

/** Lux to 2–3 significant digits: 0.52, 5.2, 52, 520, 5.2k, 52k. */
export function fmtLux(v) {
  if (v >= 1000) return `${+(v / 1000).toPrecision(v >= 10000 ? 3 : 2)}k`;
  if (v >= 100) return v.toFixed(0);
  return `${+v.toPrecision(2)}`;
}

/** A uniformity ratio (U₀, Emin/Emax) to two decimals; "–" for an unlit grid's, which
 *  the server reports as null (a ratio of zeros has no value). */
export function fmtRatio(x) {
  return x == null ? "–" : x.toFixed(2);
}
