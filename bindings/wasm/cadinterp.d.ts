// Type declarations of cadinterp.mjs (the reference manual is README.md next to this file).

export declare const STATUS_NAMES: readonly string[];

export declare class CadinterpError extends Error {
  /** The C ABI's cadinterp_status value. */
  readonly status: number;
  /** Its name, e.g. "CADINTERP_E_OUTSIDE_DOMAIN". */
  readonly statusName: string;
}

export interface LoadOptions {
  wasmBinary?: ArrayBuffer | Uint8Array;
  locateFile?: (name: string, prefix: string) => string;
}

export declare function load(options?: LoadOptions): Promise<Library>;

export interface Library {
  readonly version: string;
  open(bytes: ArrayBuffer | ArrayBufferView): Asset;
  memoryStats(): { heapBytes: number; mallocBytes: number };
}

export type Point = ArrayLike<number>;

export interface Parameter { name: string; unit: string; lower: number; upper: number }
export interface FieldInfo {
  name: string;
  location: 'vertex' | 'tet';
  components: number;
  maxAbsError: number;
  /** The values' unit as the builder's host gave it ("MPa", "mm", ...); "" when unknown (format 1.0 assets). */
  unit: string;
}
export interface Region { name: string; kind: string; faceTags: Int32Array }
export interface InfeasiblePoint { x: Float64Array; message: string }
export interface Provenance { builderVersion: string; host: string; options: string }

export interface Mesh {
  element: number;
  vertexCount: number;
  tetCount: number;
  triangleCount: number;
  positions: Float32Array;
  tets: Uint32Array;
  triangles: Uint32Array;
  triangleTags: Int32Array;
  fields: Record<string, Float32Array>;
}

export interface MeshGrad {
  element: number;
  vertexCount: number;
  positions: Float32Array;
  dpositions: Float32Array;
  dfields: Record<string, Float32Array>;
}

export interface Properties {
  volume: number;
  mass: number;
  area: number;
  frontalArea: number;
  centroid: number[];
  inertia: number[];
  grad?: Properties[];
}

export interface Asset {
  readonly dim: number;
  readonly degree: number;
  readonly elementCount: number;
  readonly parameters: Parameter[];
  readonly fields: FieldInfo[];
  readonly regions: Region[];
  readonly infeasiblePoints: InfeasiblePoint[];
  readonly provenance: Provenance;
  locate(x: Point): { element: number; feasible: boolean };
  errorEstimate(x: Point): number;
  setCacheBudget(bytes: number): void;
  eval(x: Point, fieldNames?: string[] | null, opts?: { copy?: boolean }): Mesh;
  /** eval restricted to chosen vertex and tet ids: positions/fields hold one row per id. */
  evalSubset(
    x: Point,
    subset: { vertices?: ArrayLike<number>; tets?: ArrayLike<number> },
    fieldNames?: string[] | null,
    opts?: { copy?: boolean },
  ): Mesh;
  grad(x: Point, fieldNames?: string[] | null, opts?: { copy?: boolean }): MeshGrad;
  vjp(x: Point, dPositions: ArrayLike<number> | null, fieldAdjoints?: Record<string, ArrayLike<number>> | null): Float64Array;
  properties(x: Point, opts?: { density?: number; direction?: ArrayLike<number>; grad?: boolean }): Properties;
  close(): void;
}
