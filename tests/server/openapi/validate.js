// Validates the REST API's OpenAPI document with swagger-parser (the
// OpenAPI 3.0 schema, $refs resolve, operationIds are unique) and checks
// what it leaves out for 3.0: each path's {parameters} are declared.
//
//   node validate.js <openapi.json | http://host:port/v1/openapi.json>
//
// Exit 0 when valid; 1 with the validator's message otherwise. It also
// checks that the validator refuses a copy with a dangling $ref, so that a
// validator that accepts anything cannot make the check pass.
'use strict';
const fs = require('fs');
const SwaggerParser = require('@apidevtools/swagger-parser');

async function load(source) {
  if (/^https?:\/\//.test(source)) {
    const response = await fetch(source);
    if (!response.ok) throw new Error(`GET ${source}: HTTP ${response.status}`);
    return response.json();
  }
  return JSON.parse(fs.readFileSync(source, 'utf8'));
}

async function main() {
  const source = process.argv[2];
  if (!source) {
    console.error('usage: node validate.js <openapi.json | URL>');
    process.exit(2);
  }
  const document = await load(source);
  // validate() dereferences in place: give it copies.
  const api = await SwaggerParser.validate(structuredClone(document));
  // swagger-parser checks path parameters only for Swagger 2.0: every
  // {parameter} of a path must be declared for each of its operations.
  for (const [path, item] of Object.entries(api.paths)) {
    const templated = [...path.matchAll(/\{([^}]+)\}/g)].map((m) => m[1]);
    for (const [method, operation] of Object.entries(item)) {
      if (method === 'parameters') continue;
      const declared = [...(item.parameters || []), ...(operation.parameters || [])]
        .filter((p) => p.in === 'path').map((p) => p.name);
      for (const name of templated)
        if (!declared.includes(name)) throw new Error(`${method.toUpperCase()} ${path} does not declare path parameter {${name}}`);
      for (const name of declared)
        if (!templated.includes(name)) throw new Error(`${method.toUpperCase()} ${path} declares {${name}}, which its path lacks`);
    }
  }
  const operations = Object.values(api.paths).reduce((n, item) => n + Object.keys(item).length, 0);
  console.log(`${source}: valid OpenAPI ${api.openapi}, ${Object.keys(api.paths).length} paths, ${operations} operations`);

  const broken = structuredClone(document);
  delete broken.components.schemas.Error;
  try {
    await SwaggerParser.validate(broken);
    console.error('the validator accepted a document with a dangling $ref to #/components/schemas/Error');
    process.exit(1);
  } catch (e) {
    console.log('the validator refuses a dangling $ref, as it must');
  }
}

main().catch((e) => {
  console.error(`${process.argv[2]}: INVALID: ${e.message}`);
  process.exit(1);
});
