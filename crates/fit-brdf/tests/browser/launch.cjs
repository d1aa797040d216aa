// The system Chromium as every browser check here starts it: headless, software WebGL
// (SwiftShader through ANGLE: this machine and CI have no GPU), and no background
// traffic. Shared by browser/panels.cjs and engines/threejs.cjs.
const { chromium } = require('playwright-core');

function launch(exe) {
  return chromium.launch({
    executablePath: exe,
    headless: true,
    args: ['--no-sandbox', '--enable-unsafe-swiftshader', '--use-angle=swiftshader',
      '--disable-background-networking', '--disable-component-update'],
  });
}

module.exports = { launch };
