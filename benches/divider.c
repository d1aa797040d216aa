/* Throughput of the divider on this machine: one AVX-512 instruction (vsqrtpd,
 * vdivpd, vsqrtps) or an add and a multiply, in ns per zmm instruction, eight
 * independent chains so that the unit, not the latency, is the limit. It is what
 * docs/performance.md ("Raw directions in f64: fewer square roots and divisions")
 * costs the f64 kernels with. Not part of the build or the tests:
 *
 *     gcc -O2 -mavx512f -o /tmp/divider benches/divider.c && /tmp/divider
 */
#include <immintrin.h>
#include <stdio.h>
#include <time.h>
static double now(){struct timespec t;clock_gettime(CLOCK_MONOTONIC,&t);return t.tv_sec+t.tv_nsec*1e-9;}
int main(){
  const long N=20000000;
  __m512d a[8]; for(int i=0;i<8;i++) a[i]=_mm512_set1_pd(1.0+i*0.1);
  __m512d one=_mm512_set1_pd(1.0000001);
  double t0=now();
  for(long k=0;k<N;k++){ for(int i=0;i<8;i++) a[i]=_mm512_sqrt_pd(_mm512_add_pd(a[i],one)); }
  double t1=now();
  for(long k=0;k<N;k++){ for(int i=0;i<8;i++) a[i]=_mm512_div_pd(one,_mm512_add_pd(a[i],one)); }
  double t2=now();
  __m512 b[8]; for(int i=0;i<8;i++) b[i]=_mm512_set1_ps(1.0f+i*0.1f);
  __m512 onef=_mm512_set1_ps(1.0000001f);
  for(long k=0;k<N;k++){ for(int i=0;i<8;i++) b[i]=_mm512_sqrt_ps(_mm512_add_ps(b[i],onef)); }
  double t3=now();
  for(long k=0;k<N;k++){ for(int i=0;i<8;i++) a[i]=_mm512_mul_pd(one,_mm512_add_pd(a[i],one)); }
  double t4=now();
  double s=0; for(int i=0;i<8;i++) s+=a[i][0]+b[i][0];
  printf("ns per zmm op: sqrtpd %.3f divpd %.3f sqrtps %.3f add+mul %.3f (%g)\n",(t1-t0)/N/8*1e9,(t2-t1)/N/8*1e9,(t3-t2)/N/8*1e9,(t4-t3)/N/8*1e9,s);
}
